#include "link/serial_transport.hpp"

#include <fcntl.h>
#include <termios.h>
#include <unistd.h>

#include <cerrno>
#include <cstring>

#include "link/fd_transport.hpp"

namespace piezoloop::hostlink {

namespace {

bool baud_constant(uint32_t baud, speed_t& out) {
    switch (baud) {
        case 9600: out = B9600; return true;
        case 19200: out = B19200; return true;
        case 38400: out = B38400; return true;
        case 57600: out = B57600; return true;
        case 115200: out = B115200; return true;
        case 230400: out = B230400; return true;
        case 460800: out = B460800; return true;
        case 921600: out = B921600; return true;
        case 1000000: out = B1000000; return true;
        case 2000000: out = B2000000; return true;
        case 3000000: out = B3000000; return true;
        case 4000000: out = B4000000; return true;
        default: return false;
    }
}

}  // namespace

std::unique_ptr<Transport> open_serial(const std::string& path, uint32_t baud) {
    const std::string address = "serial:" + path + "@" + std::to_string(baud);
    speed_t speed{};
    if (!baud_constant(baud, speed))
        throw LinkError(address + ": unsupported baud rate (9600, 19200, 38400, 57600, 115200, 230400, 460800, "
                                  "921600, 1000000, 2000000, 3000000, 4000000)");
    const int fd = ::open(path.c_str(), O_RDWR | O_NOCTTY | O_CLOEXEC);
    if (fd < 0) throw LinkError(address + ": cannot open: " + std::strerror(errno));
    termios t{};
    if (::tcgetattr(fd, &t) != 0) {
        const int e = errno;
        ::close(fd);
        throw LinkError(address + ": not a serial device: " + std::strerror(e));
    }
    // Raw bytes: no echo, no line editing, no CR/LF translation, no
    // software or hardware flow control; 8 data bits, no parity, 1 stop bit.
    ::cfmakeraw(&t);
    t.c_cflag |= CLOCAL | CREAD;
    t.c_cflag &= ~(CSTOPB | PARENB | CRTSCTS);
    t.c_iflag &= ~(IXON | IXOFF | IXANY);
    t.c_cc[VMIN] = 0;
    t.c_cc[VTIME] = 0;
    ::cfsetispeed(&t, speed);
    ::cfsetospeed(&t, speed);
    if (::tcsetattr(fd, TCSANOW, &t) != 0) {
        const int e = errno;
        ::close(fd);
        throw LinkError(address + ": cannot configure the port: " + std::strerror(e));
    }
    ::tcflush(fd, TCIOFLUSH);
    return std::make_unique<FdTransport>(fd, address, false);
}

}  // namespace piezoloop::hostlink
