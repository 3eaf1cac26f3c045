// TCP byte stream to a board: emulated boards (QEMU -serial tcp:...,server)
// or a network bridge. Nagle is off so small requests are not held back.
#pragma once

#include <cstdint>
#include <memory>
#include <string>

#include "link/transport.hpp"

namespace piezoloop::hostlink {

// Connects (waiting at most connect_timeout); throws LinkError
// "tcp:HOST:PORT: connection refused" etc.
std::unique_ptr<Transport> open_tcp(const std::string& host, uint16_t port,
                                    std::chrono::milliseconds connect_timeout = std::chrono::milliseconds(3000));

// A transport over an already connected stream socket (tests: socketpair).
// Takes ownership of fd.
std::unique_ptr<Transport> adopt_socket(int fd, const std::string& address);

}  // namespace piezoloop::hostlink
