// A byte stream to a board: TCP (emulated boards, QEMU -serial tcp:),
// USB bulk (the STM32 vendor device, libusb) or a serial tty (UART bridges).
// The link protocol (common/piezoloop/link/) frames its own messages, so a
// transport only moves bytes, in order, without loss or duplication.
//
// Errors are exceptions (host code): LinkError with a message that names the
// device and what failed ("tcp:localhost:4000: connection refused",
// "usb:SN123: device unplugged").
#pragma once

#include <chrono>
#include <cstddef>
#include <cstdint>
#include <memory>
#include <span>
#include <stdexcept>
#include <string>

namespace piezoloop::hostlink {

struct LinkError : std::runtime_error {
    using std::runtime_error::runtime_error;
};

class Transport {
public:
    virtual ~Transport() = default;
    // Sends every byte (blocking until handed to the OS / device), or throws.
    virtual void write(std::span<const uint8_t> bytes) = 0;
    // Waits at most `timeout` for bytes; returns how many were stored in
    // `buffer` (0: nothing arrived in time). Throws on a closed link.
    virtual std::size_t read(std::span<uint8_t> buffer, std::chrono::milliseconds timeout) = 0;
    // The address as the user would write it after --device.
    virtual std::string address() const = 0;
};

// Opens "tcp:HOST:PORT", "usb", "usb:SERIAL" or "serial:PATH[@BAUD]".
// Throws LinkError naming the allowed forms for anything else.
std::unique_ptr<Transport> open_transport(const std::string& address);

}  // namespace piezoloop::hostlink
