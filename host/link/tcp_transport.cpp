#include "link/tcp_transport.hpp"

#include <fcntl.h>
#include <netdb.h>
#include <netinet/in.h>
#include <netinet/tcp.h>
#include <poll.h>
#include <sys/socket.h>
#include <unistd.h>

#include <cerrno>
#include <cstring>

#include "link/fd_transport.hpp"

namespace piezoloop::hostlink {

namespace {

// Non-blocking connect bounded by the timeout; returns the connected fd or
// -1 with errno set.
int connect_with_timeout(const addrinfo* a, std::chrono::milliseconds timeout) {
    const int fd = ::socket(a->ai_family, a->ai_socktype | SOCK_CLOEXEC, a->ai_protocol);
    if (fd < 0) return -1;
    const int flags = ::fcntl(fd, F_GETFL, 0);
    ::fcntl(fd, F_SETFL, flags | O_NONBLOCK);
    int rc = ::connect(fd, a->ai_addr, a->ai_addrlen);
    if (rc < 0 && errno == EINPROGRESS) {
        pollfd p{fd, POLLOUT, 0};
        rc = ::poll(&p, 1, static_cast<int>(timeout.count()));
        if (rc == 0) {
            ::close(fd);
            errno = ETIMEDOUT;
            return -1;
        }
        int err = 0;
        socklen_t len = sizeof err;
        ::getsockopt(fd, SOL_SOCKET, SO_ERROR, &err, &len);
        if (rc < 0 || err != 0) {
            ::close(fd);
            errno = err != 0 ? err : errno;
            return -1;
        }
    } else if (rc < 0) {
        const int e = errno;
        ::close(fd);
        errno = e;
        return -1;
    }
    ::fcntl(fd, F_SETFL, flags & ~O_NONBLOCK);
    return fd;
}

}  // namespace

std::unique_ptr<Transport> adopt_socket(int fd, const std::string& address) {
    const int one = 1;
    ::setsockopt(fd, IPPROTO_TCP, TCP_NODELAY, &one, sizeof one);  // fails harmlessly on non-TCP sockets
    return std::make_unique<FdTransport>(fd, address, true);
}

std::unique_ptr<Transport> open_tcp(const std::string& host, uint16_t port, std::chrono::milliseconds connect_timeout) {
    const std::string address = "tcp:" + host + ":" + std::to_string(port);
    addrinfo hints{};
    hints.ai_family = AF_UNSPEC;
    hints.ai_socktype = SOCK_STREAM;
    addrinfo* list = nullptr;
    const int g = ::getaddrinfo(host.c_str(), std::to_string(port).c_str(), &hints, &list);
    if (g != 0) throw LinkError(address + ": cannot resolve host: " + ::gai_strerror(g));
    int fd = -1, err = 0;
    for (const addrinfo* a = list; a != nullptr && fd < 0; a = a->ai_next) {
        fd = connect_with_timeout(a, connect_timeout);
        if (fd < 0) err = errno;
    }
    ::freeaddrinfo(list);
    if (fd < 0) {
        std::string why = err == ECONNREFUSED ? "connection refused (is the board or `piezoloop emulate` running?)"
                          : err == ETIMEDOUT  ? "connection timed out"
                                              : std::strerror(err);
        throw LinkError(address + ": " + why);
    }
    return adopt_socket(fd, address);
}

}  // namespace piezoloop::hostlink
