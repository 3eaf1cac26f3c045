// A Transport over a POSIX file descriptor (socket or tty): poll() for the
// read timeout, write() until every byte is out. Shared by the TCP and the
// serial transports.
#pragma once

#include <string>

#include "link/transport.hpp"

namespace piezoloop::hostlink {

class FdTransport : public Transport {
public:
    FdTransport(int fd, std::string address, bool socket);
    ~FdTransport() override;
    FdTransport(const FdTransport&) = delete;
    FdTransport& operator=(const FdTransport&) = delete;

    void write(std::span<const uint8_t> bytes) override;
    std::size_t read(std::span<uint8_t> buffer, std::chrono::milliseconds timeout) override;
    std::string address() const override { return address_; }

private:
    [[noreturn]] void fail(const std::string& what, int err) const;
    int fd_;
    std::string address_;
    bool socket_;  // send(MSG_NOSIGNAL): a closed peer is an error, not SIGPIPE
};

}  // namespace piezoloop::hostlink
