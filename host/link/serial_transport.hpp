// Serial tty (USB-UART bridges, the board's ST-LINK VCP): raw 8N1, no flow
// control, at a given baud rate.
#pragma once

#include <cstdint>
#include <memory>
#include <string>

#include "link/transport.hpp"

namespace piezoloop::hostlink {

// Throws LinkError naming the path for a missing device, a baud rate the
// host does not support, or a failed termios setup.
std::unique_ptr<Transport> open_serial(const std::string& path, uint32_t baud);

}  // namespace piezoloop::hostlink
