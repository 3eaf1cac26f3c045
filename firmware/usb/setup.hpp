// USB control transfers: the 8-byte SETUP packet and the constants of the
// standard requests (USB 2.0 specification, chapter 9: Table 9-2 "Format of
// Setup Data", Table 9-4 "Standard Request Codes", Table 9-5 "Descriptor
// Types", Table 9-6 "Standard Feature Selectors").
//
// Hardware-independent: used by the device controller driver of a board
// (bsp/stm32h743/usb_otg_fs.cpp) and tested on the host
// (tests/common/usb/test_control.cpp).
#pragma once

#include <cstdint>

namespace piezoloop::usb {

// bmRequestType fields.
inline constexpr uint8_t kDirDeviceToHost = 0x80;
enum class RequestType : uint8_t { kStandard = 0, kClass = 1, kVendor = 2, kReserved = 3 };
enum class Recipient : uint8_t { kDevice = 0, kInterface = 1, kEndpoint = 2, kOther = 3 };

// bRequest of the standard requests.
enum class StandardRequest : uint8_t {
    kGetStatus = 0,
    kClearFeature = 1,
    kSetFeature = 3,
    kSetAddress = 5,
    kGetDescriptor = 6,
    kSetDescriptor = 7,
    kGetConfiguration = 8,
    kSetConfiguration = 9,
    kGetInterface = 10,
    kSetInterface = 11,
    kSynchFrame = 12,
};

// Descriptor types (high byte of wValue in GET_DESCRIPTOR).
enum class DescriptorType : uint8_t {
    kDevice = 1,
    kConfiguration = 2,
    kString = 3,
    kInterface = 4,
    kEndpoint = 5,
    kDeviceQualifier = 6,
    kOtherSpeedConfiguration = 7,
    kInterfacePower = 8,
};

// Feature selectors.
inline constexpr uint16_t kFeatureEndpointHalt = 0;
inline constexpr uint16_t kFeatureDeviceRemoteWakeup = 1;
inline constexpr uint16_t kFeatureTestMode = 2;

struct SetupPacket {
    uint8_t bmRequestType = 0;
    uint8_t bRequest = 0;
    uint16_t wValue = 0;
    uint16_t wIndex = 0;
    uint16_t wLength = 0;

    // Little-endian, as on the wire (Table 9-2).
    static constexpr SetupPacket parse(const uint8_t* b) {
        SetupPacket s;
        s.bmRequestType = b[0];
        s.bRequest = b[1];
        s.wValue = static_cast<uint16_t>(b[2] | (b[3] << 8));
        s.wIndex = static_cast<uint16_t>(b[4] | (b[5] << 8));
        s.wLength = static_cast<uint16_t>(b[6] | (b[7] << 8));
        return s;
    }

    constexpr bool device_to_host() const { return (bmRequestType & kDirDeviceToHost) != 0; }
    constexpr RequestType type() const { return static_cast<RequestType>((bmRequestType >> 5) & 3u); }
    constexpr Recipient recipient() const { return static_cast<Recipient>(bmRequestType & 0x1Fu); }
    constexpr bool is(StandardRequest r) const {
        return type() == RequestType::kStandard && bRequest == static_cast<uint8_t>(r);
    }
};

}  // namespace piezoloop::usb
