// open_transport: the --device address forms and the transport behind each.
#include "link/transport.hpp"

#include <cstdlib>
#include <stdexcept>
#include <string>

#include "link/tcp_transport.hpp"
#include "link/serial_transport.hpp"

#include "link/usb_transport.hpp"

namespace piezoloop::hostlink {

namespace {

const char* const kForms =
    "accepted forms: tcp:HOST:PORT (emulated board, see `piezoloop emulate`), usb (the only USB board), "
    "usb:SERIAL, serial:PATH[@BAUD] (UART bridge, default 115200 baud)";

// A malformed address is bad input (exit 2), not a link failure.
[[noreturn]] void bad(const std::string& address, const std::string& why) {
    throw std::invalid_argument("--device " + (address.empty() ? std::string("''") : address) + ": " + why + "; " +
                                kForms);
}

// Whole string is a decimal number in [lo, hi].
bool parse_uint(const std::string& s, unsigned long lo, unsigned long hi, unsigned long& out) {
    if (s.empty() || s.size() > 10) return false;
    for (const char c : s)
        if (c < '0' || c > '9') return false;
    out = std::strtoul(s.c_str(), nullptr, 10);
    return out >= lo && out <= hi;
}

}  // namespace

std::unique_ptr<Transport> open_transport(const std::string& address) {
    if (address.rfind("tcp:", 0) == 0) {
        const std::string rest = address.substr(4);
        const std::size_t colon = rest.rfind(':');
        if (colon == std::string::npos || colon == 0) bad(address, "expected tcp:HOST:PORT");
        std::string host = rest.substr(0, colon);
        if (host.size() >= 2 && host.front() == '[' && host.back() == ']') host = host.substr(1, host.size() - 2);
        unsigned long port = 0;
        if (!parse_uint(rest.substr(colon + 1), 1, 65535, port)) bad(address, "port must be a number in 1..65535");
        return open_tcp(host, static_cast<uint16_t>(port));
    }
    if (address == "usb" || address.rfind("usb:", 0) == 0) {
        const std::string serial = address.size() > 4 ? address.substr(4) : std::string();
        if (address.size() == 4) bad(address, "empty USB serial number");
        return open_usb(serial);
    }
    if (address.rfind("serial:", 0) == 0) {
        std::string path = address.substr(7);
        unsigned long baud = 115200;
        const std::size_t at = path.rfind('@');
        if (at != std::string::npos) {
            if (!parse_uint(path.substr(at + 1), 1, 100000000, baud)) bad(address, "baud rate must be a number");
            path = path.substr(0, at);
        }
        if (path.empty()) bad(address, "expected serial:PATH[@BAUD]");
        return open_serial(path, static_cast<uint32_t>(baud));
    }
    bad(address, "unknown transport");
}

}  // namespace piezoloop::hostlink
