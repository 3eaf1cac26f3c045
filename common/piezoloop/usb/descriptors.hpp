// Descriptors of the piezoloop USB device: a full-speed, vendor-specific
// device with one interface and two bulk endpoints (EP1 OUT for commands
// and parameter sets, EP1 IN for replies and recorder streams), built at
// compile time. Layouts: USB 2.0 specification, Table 9-8 (device),
// 9-10 (configuration), 9-12 (interface), 9-13 (endpoint), 9-15/9-16
// (string descriptors: zero = LANGID list, others UTF-16LE).
//
// Vendor class (bInterfaceClass 0xFF) needs no class driver: libusb opens
// it directly on Linux and macOS (Windows needs WinUSB bound to it; a
// Microsoft OS 2.0 descriptor set would do that automatically -- not yet).
#pragma once

#include <array>
#include <cstddef>
#include <cstdint>

namespace piezoloop::usb {

inline constexpr uint8_t kEp0MaxPacket = 64;        // full speed: 8, 16, 32 or 64
inline constexpr uint8_t kBulkOutEndpoint = 0x01;   // EP1 OUT
inline constexpr uint8_t kBulkInEndpoint = 0x81;    // EP1 IN
inline constexpr uint16_t kBulkMaxPacket = 64;      // the only legal full-speed bulk sizes are 8..64
inline constexpr uint8_t kConfigurationValue = 1;
inline constexpr uint8_t kInterfaceNumber = 0;

struct DeviceIdentity {
    // pid.codes (VID 0x1209, open-source hardware); 0x0001 is its test PID,
    // to be replaced by an allocated one before boards are distributed.
    uint16_t vendor_id = 0x1209;
    uint16_t product_id = 0x0001;
    uint16_t device_release_bcd = 0x0100;  // 1.00
    uint8_t max_power_2mA = 50;            // 100 mA, bus powered
};

inline constexpr uint8_t kStringLangIds = 0;
inline constexpr uint8_t kStringManufacturer = 1;
inline constexpr uint8_t kStringProduct = 2;
inline constexpr uint8_t kStringSerial = 3;
inline constexpr uint16_t kLangIdEnglishUs = 0x0409;

constexpr uint8_t lo(uint16_t v) { return static_cast<uint8_t>(v & 0xFFu); }
constexpr uint8_t hi(uint16_t v) { return static_cast<uint8_t>(v >> 8); }

constexpr std::array<uint8_t, 18> device_descriptor(const DeviceIdentity& id) {
    return {18,                         // bLength
            1,                          // bDescriptorType: DEVICE
            lo(0x0200), hi(0x0200),     // bcdUSB 2.00
            0x00, 0x00, 0x00,           // class/subclass/protocol: per interface
            kEp0MaxPacket,              // bMaxPacketSize0
            lo(id.vendor_id), hi(id.vendor_id),
            lo(id.product_id), hi(id.product_id),
            lo(id.device_release_bcd), hi(id.device_release_bcd),
            kStringManufacturer, kStringProduct, kStringSerial,
            1};                         // bNumConfigurations
}

inline constexpr std::size_t kConfigurationTotalLength = 9 + 9 + 7 + 7;

constexpr std::array<uint8_t, kConfigurationTotalLength> configuration_descriptor(const DeviceIdentity& id) {
    return {// configuration
            9, 2, lo(kConfigurationTotalLength), hi(kConfigurationTotalLength),
            1,                    // bNumInterfaces
            kConfigurationValue,  // bConfigurationValue
            0,                    // iConfiguration
            0x80,                 // bmAttributes: reserved bit 7 set; bus powered, no remote wakeup
            id.max_power_2mA,
            // interface 0: vendor specific, two endpoints
            9, 4, kInterfaceNumber, 0 /* bAlternateSetting */, 2 /* bNumEndpoints */, 0xFF, 0x00, 0x00,
            0 /* iInterface */,
            // EP1 OUT bulk
            7, 5, kBulkOutEndpoint, 0x02, lo(kBulkMaxPacket), hi(kBulkMaxPacket), 0,
            // EP1 IN bulk
            7, 5, kBulkInEndpoint, 0x02, lo(kBulkMaxPacket), hi(kBulkMaxPacket), 0};
}

// String descriptor zero: the supported LANGIDs.
constexpr std::array<uint8_t, 4> langid_descriptor() { return {4, 3, lo(kLangIdEnglishUs), hi(kLangIdEnglishUs)}; }

// An ASCII string as a string descriptor (UTF-16LE) into out; returns its
// length (0 if out is too small or the text is not 7-bit ASCII or longer
// than the 126 characters a descriptor can hold).
constexpr std::size_t string_descriptor(const char* ascii, uint8_t* out, std::size_t capacity) {
    std::size_t n = 0;
    while (ascii[n] != '\0') {
        if (static_cast<unsigned char>(ascii[n]) > 0x7F) return 0;
        ++n;
    }
    const std::size_t length = 2 + 2 * n;
    if (n > 126 || length > capacity) return 0;
    out[0] = static_cast<uint8_t>(length);
    out[1] = 3;
    for (std::size_t i = 0; i < n; ++i) {
        out[2 + 2 * i] = static_cast<uint8_t>(ascii[i]);
        out[3 + 2 * i] = 0;
    }
    return length;
}

}  // namespace piezoloop::usb
