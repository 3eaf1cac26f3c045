// USB device on the NUCLEO-H743ZI2's user connector (CN13, micro-AB): the
// STM32H743's second OTG core ("OTG2_FS", a Synopsys DWC2 at 0x40080000,
// interrupt 101) with its embedded full-speed PHY on PA11 (DM) / PA12 (DP),
// AF10. A vendor-class device with bulk EP1 OUT and EP1 IN (64 bytes); the
// chapter-9 logic is common/piezoloop/usb/control.hpp (host-tested), this is the
// register-level part only, written from RM0433 §57 ("USB on-the-go
// high-speed", programming model). NOT RUN: no hardware here.
//
// Data path: EP1 OUT packets go into rx (when a whole packet fits; else the
// endpoint NAKs until the main loop has read enough), tx is sent on EP1 IN
// in packets of up to 64 bytes. rx/tx are SPSC rings between the USB
// interrupt and the main loop.
#pragma once

#include <cstddef>
#include <cstdint>

#include "piezoloop/usb/byte_ring.hpp"

namespace piezoloop::bsp::stm32::usbfs {

inline constexpr int kIrq = 101;  // OTG_FS

using Ring = usb::ByteRing<2048>;

// Clocks (PLL1Q 48 MHz must be running), PHY supply, pins, core reset,
// device mode, FIFOs, interrupts, soft connect. `serial` is the serial
// number string the host enumerates (the unique-ID text; not copied: it
// must stay valid), set before the soft connect. False if the core does
// not come out of reset.
bool init(const char* serial);

// Main loop: bytes received from the host / queued for the host.
std::size_t read(uint8_t* out, std::size_t n);
std::size_t write(const uint8_t* data, std::size_t n);
bool configured();

}  // namespace piezoloop::bsp::stm32::usbfs
