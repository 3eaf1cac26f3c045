// USB transport to the STM32 vendor-bulk board (its USB side: firmware/bsp/stm32h743/usb_otg_fs.*): libusb-1.0,
// VID 0x1209 / PID 0x0001, vendor interface 0, bulk EP1 OUT 0x01 / EP1 IN
// 0x81 (the constants come from common/piezoloop/usb/descriptors.hpp, so host and
// firmware cannot drift apart).
//
// Data path: several asynchronous IN transfers stay queued on EP1 IN at all
// times, so the host controller keeps polling the board while the client
// parses; a libusb event thread completes them into a byte queue that read()
// drains. write() submits one OUT transfer and waits for its completion.
//
// Errors are LinkError naming the board ("usb:SN123: device unplugged"):
// no board / several boards without a serial, access denied (the udev rule
// in tools/udev/, docs/boards.md "USB access (udev)"), interface busy,
// unplug (transfer status or submit result NO_DEVICE).
#pragma once

#include <cstdint>
#include <memory>
#include <string>
#include <vector>

#include "link/transport.hpp"

namespace piezoloop::hostlink {

// Opens the board whose serial number string is `serial`; with an empty
// serial the only board present (LinkError if there are none or several).
std::unique_ptr<Transport> open_usb(const std::string& serial);

struct UsbBoard {
    std::string serial;    // empty if the board could not be opened (see product)
    std::string product;   // product string, or why it could not be read
    std::string bus_port;  // "BUS-PORT[.PORT...]" as in /sys/bus/usb/devices
    uint16_t vid = 0, pid = 0;
};

// Every attached device with piezoloop's VID/PID, in bus/port order.
std::vector<UsbBoard> list_usb_boards();

}  // namespace piezoloop::hostlink
