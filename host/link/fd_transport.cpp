#include "link/fd_transport.hpp"

#include <poll.h>
#include <sys/socket.h>
#include <unistd.h>

#include <cerrno>
#include <cstring>

namespace piezoloop::hostlink {

FdTransport::FdTransport(int fd, std::string address, bool socket)
    : fd_(fd), address_(std::move(address)), socket_(socket) {}

FdTransport::~FdTransport() {
    if (fd_ >= 0) ::close(fd_);
}

void FdTransport::fail(const std::string& what, int err) const {
    throw LinkError(address_ + ": " + what + (err != 0 ? std::string(": ") + std::strerror(err) : std::string()));
}

void FdTransport::write(std::span<const uint8_t> bytes) {
    std::size_t done = 0;
    while (done < bytes.size()) {
        const ssize_t n = socket_ ? ::send(fd_, bytes.data() + done, bytes.size() - done, MSG_NOSIGNAL)
                                  : ::write(fd_, bytes.data() + done, bytes.size() - done);
        if (n < 0) {
            if (errno == EINTR) continue;
            if (errno == EAGAIN || errno == EWOULDBLOCK) {
                pollfd p{fd_, POLLOUT, 0};
                ::poll(&p, 1, 100);
                continue;
            }
            if (errno == EPIPE || errno == ECONNRESET) fail("link closed by the device", 0);
            fail("write failed", errno);
        }
        done += static_cast<std::size_t>(n);
    }
}

std::size_t FdTransport::read(std::span<uint8_t> buffer, std::chrono::milliseconds timeout) {
    if (buffer.empty()) return 0;
    const auto deadline = std::chrono::steady_clock::now() + timeout;
    for (;;) {
        const auto left = std::chrono::duration_cast<std::chrono::milliseconds>(deadline - std::chrono::steady_clock::now());
        pollfd p{fd_, POLLIN, 0};
        const int r = ::poll(&p, 1, left.count() > 0 ? static_cast<int>(left.count()) : 0);
        if (r < 0) {
            if (errno == EINTR) continue;
            fail("poll failed", errno);
        }
        if (r == 0) return 0;
        const ssize_t n = ::read(fd_, buffer.data(), buffer.size());
        if (n > 0) return static_cast<std::size_t>(n);
        if (n == 0) fail("link closed by the device", 0);
        if (errno == EINTR || errno == EAGAIN || errno == EWOULDBLOCK) {
            if (std::chrono::steady_clock::now() >= deadline) return 0;
            continue;
        }
        if (errno == ECONNRESET) fail("link closed by the device", 0);
        fail("read failed", errno);
    }
}

}  // namespace piezoloop::hostlink
