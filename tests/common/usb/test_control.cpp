// Chapter-9 request handling of the firmware's USB device
// (firmware/usb/control.hpp) against the USB 2.0 specification §9.4, driven
// through a fake device controller that records what the handler asks of
// the hardware. Replies are checked byte for byte (no tolerances: protocol).
#include <gtest/gtest.h>

#include <array>
#include <cstdint>
#include <cstring>
#include <vector>

#include "usb/control.hpp"
#include "usb/serial_number.hpp"

using namespace piezoloop::usb;
using Kind = ControlReply::Kind;

namespace {

struct FakeHw {
    std::vector<int> addresses;  // every set_address call
    int configure_calls_on = 0, configure_calls_off = 0;
    bool configured = false;
    bool stalled_out = false, stalled_in = false;
    std::vector<uint8_t> vendor_out;
    std::array<uint8_t, 100> vendor_blob{};

    void set_address(uint8_t a) { addresses.push_back(a); }
    void configure_endpoints(bool on) {
        configured = on;
        (on ? configure_calls_on : configure_calls_off)++;
        if (on) stalled_out = stalled_in = false;
    }
    void set_endpoint_stall(uint8_t ep, bool s) { (ep == 0x81 ? stalled_in : stalled_out) = s; }
    bool endpoint_stalled(uint8_t ep) const {
        if (ep == 0x81) return stalled_in;
        if (ep == 0x01) return stalled_out;
        return false;
    }
    // Vendor request 0x10 IN: `wValue` bytes of a blob; 0x11 OUT: accepts wLength bytes.
    ControlReply vendor_setup(const SetupPacket& s, uint8_t* buffer, std::size_t capacity) {
        if (s.bRequest == 0x10 && s.device_to_host()) {
            for (std::size_t i = 0; i < vendor_blob.size(); ++i) vendor_blob[i] = static_cast<uint8_t>(i);
            ControlReply r;
            r.kind = Kind::kDataIn;
            r.data = vendor_blob.data();
            r.length = s.wValue;
            return r;
        }
        if (s.bRequest == 0x11 && !s.device_to_host() && s.wLength <= capacity) {
            (void)buffer;
            ControlReply r;
            r.kind = Kind::kDataOut;
            r.length = s.wLength;
            return r;
        }
        return ControlReply::stall();
    }
    void vendor_data_out(const SetupPacket&, const uint8_t* d, std::size_t n) { vendor_out.assign(d, d + n); }
};

SetupPacket req(uint8_t type, uint8_t request, uint16_t value, uint16_t index, uint16_t length) {
    return SetupPacket{type, request, value, index, length};
}

// bmRequestType values (Table 9-2).
constexpr uint8_t kInDevice = 0x80, kOutDevice = 0x00, kInInterface = 0x81, kOutInterface = 0x01,
                  kInEndpoint = 0x82, kOutEndpoint = 0x02, kVendorIn = 0xC0, kVendorOut = 0x40,
                  kClassIn = 0xA1;

class UsbControl : public ::testing::Test {
protected:
    FakeHw hw;
    ControlHandler<FakeHw> h{hw, DeviceIdentity{}, "piezoloop", "piezo servo", "0001", AddressTiming::kAtSetup};

    std::vector<uint8_t> in(const ControlReply& r) { return {r.data, r.data + r.length}; }
    void address(uint8_t a) {
        ASSERT_EQ(h.setup(req(kOutDevice, 5, a, 0, 0)).kind, Kind::kStatusIn);
        h.status_stage_done();
    }
    void configure() {
        address(7);
        ASSERT_EQ(h.setup(req(kOutDevice, 9, 1, 0, 0)).kind, Kind::kStatusIn);
        h.status_stage_done();
    }
};

}  // namespace

TEST(UsbSetup, ParsesLittleEndianFields) {
    // GET_DESCRIPTOR(device) with wLength 64, as Linux sends it first.
    const uint8_t raw[8] = {0x80, 0x06, 0x00, 0x01, 0x00, 0x00, 0x40, 0x00};
    const SetupPacket s = SetupPacket::parse(raw);
    EXPECT_EQ(s.bmRequestType, 0x80);
    EXPECT_EQ(s.bRequest, 6);
    EXPECT_EQ(s.wValue, 0x0100);
    EXPECT_EQ(s.wIndex, 0);
    EXPECT_EQ(s.wLength, 64);
    EXPECT_TRUE(s.device_to_host());
    EXPECT_EQ(s.type(), RequestType::kStandard);
    EXPECT_EQ(s.recipient(), Recipient::kDevice);
    EXPECT_TRUE(s.is(StandardRequest::kGetDescriptor));
    const uint8_t vendor[8] = {0x41, 0x22, 0x34, 0x12, 0x78, 0x56, 0x02, 0x01};
    const SetupPacket v = SetupPacket::parse(vendor);
    EXPECT_FALSE(v.device_to_host());
    EXPECT_EQ(v.type(), RequestType::kVendor);
    EXPECT_EQ(v.recipient(), Recipient::kInterface);
    EXPECT_EQ(v.wValue, 0x1234);
    EXPECT_EQ(v.wIndex, 0x5678);
    EXPECT_EQ(v.wLength, 0x0102);
}

TEST_F(UsbControl, EnumeratesLikeAHostDoes) {
    EXPECT_EQ(h.state(), DeviceState::kDefault);
    // 1. Device descriptor at address 0, wLength 64: 18 bytes, short packet ends it.
    ControlReply r = h.setup(req(kInDevice, 6, 0x0100, 0, 64));
    ASSERT_EQ(r.kind, Kind::kDataIn);
    const auto device = device_descriptor(DeviceIdentity{});
    EXPECT_EQ(in(r), std::vector<uint8_t>(device.begin(), device.end()));
    EXPECT_FALSE(r.zero_length_packet);
    // 2. SET_ADDRESS: DWC2 takes the address at once; the state changes after the status stage.
    r = h.setup(req(kOutDevice, 5, 42, 0, 0));
    EXPECT_EQ(r.kind, Kind::kStatusIn);
    EXPECT_EQ(hw.addresses, std::vector<int>{42});
    EXPECT_EQ(h.state(), DeviceState::kDefault);
    h.status_stage_done();
    EXPECT_EQ(h.state(), DeviceState::kAddress);
    EXPECT_EQ(h.address(), 42);
    // 3. Configuration header (9), then all of it (wLength 255 -> 32).
    r = h.setup(req(kInDevice, 6, 0x0200, 0, 9));
    EXPECT_EQ(r.length, 9);
    r = h.setup(req(kInDevice, 6, 0x0200, 0, 255));
    EXPECT_EQ(r.length, 32);
    EXPECT_FALSE(r.zero_length_packet) << "32 is not a multiple of 64";
    // 4. Strings: LANGIDs, then the product in US English.
    r = h.setup(req(kInDevice, 6, 0x0300, 0, 255));
    EXPECT_EQ(in(r), (std::vector<uint8_t>{4, 3, 0x09, 0x04}));
    r = h.setup(req(kInDevice, 6, 0x0302, 0x0409, 255));
    ASSERT_EQ(r.kind, Kind::kDataIn);
    EXPECT_EQ(r.length, 2 + 2 * std::strlen("piezo servo"));
    EXPECT_EQ(r.data[2], 'p');
    EXPECT_EQ(r.data[3], 0);
    // 5. SET_CONFIGURATION(1) opens the bulk endpoints.
    EXPECT_EQ(h.setup(req(kOutDevice, 9, 1, 0, 0)).kind, Kind::kStatusIn);
    EXPECT_EQ(h.state(), DeviceState::kConfigured);
    EXPECT_TRUE(hw.configured);
    r = h.setup(req(kInDevice, 8, 0, 0, 1));
    EXPECT_EQ(in(r), std::vector<uint8_t>{1});
}

TEST(UsbControlTiming, AddressAfterStatusForOtherControllers) {
    FakeHw hw;
    ControlHandler<FakeHw> h{hw, DeviceIdentity{}, "m", "p", "s", AddressTiming::kAfterStatus};
    EXPECT_EQ(h.setup(req(kOutDevice, 5, 9, 0, 0)).kind, Kind::kStatusIn);
    EXPECT_TRUE(hw.addresses.empty()) << "the status stage still runs at address 0 (§9.4.6)";
    h.status_stage_done();
    EXPECT_EQ(hw.addresses, std::vector<int>{9});
    EXPECT_EQ(h.state(), DeviceState::kAddress);
}

TEST_F(UsbControl, SetAddressZeroReturnsToDefault) {
    address(5);
    address(0);
    EXPECT_EQ(h.state(), DeviceState::kDefault);
}

TEST_F(UsbControl, SetAddressErrors) {
    EXPECT_EQ(h.setup(req(kOutDevice, 5, 128, 0, 0)).kind, Kind::kStall) << "addresses are 0..127";
    EXPECT_EQ(h.setup(req(kOutDevice, 5, 3, 1, 0)).kind, Kind::kStall) << "wIndex must be 0";
    configure();
    EXPECT_EQ(h.setup(req(kOutDevice, 5, 3, 0, 0)).kind, Kind::kStall) << "not specified in Configured";
}

TEST_F(UsbControl, DescriptorRequestErrors) {
    EXPECT_EQ(h.setup(req(kInDevice, 6, 0x0600, 0, 10)).kind, Kind::kStall)
        << "device_qualifier: a full-speed-only device answers with a request error (§9.6.2)";
    EXPECT_EQ(h.setup(req(kInDevice, 6, 0x0700, 0, 9)).kind, Kind::kStall) << "other_speed_configuration";
    EXPECT_EQ(h.setup(req(kInDevice, 6, 0x0201, 0, 9)).kind, Kind::kStall) << "only configuration index 0";
    EXPECT_EQ(h.setup(req(kInDevice, 6, 0x0304, 0x0409, 255)).kind, Kind::kStall) << "no string 4";
    EXPECT_EQ(h.setup(req(kInDevice, 6, 0x0301, 0x0407, 255)).kind, Kind::kStall) << "only LANGID 0x0409";
    EXPECT_EQ(h.setup(req(kInDevice, 6, 0x2100, 0, 9)).kind, Kind::kStall) << "no class descriptors";
}

TEST_F(UsbControl, ShortRepliesTruncateToWLength) {
    const ControlReply r = h.setup(req(kInDevice, 6, 0x0100, 0, 8));
    ASSERT_EQ(r.kind, Kind::kDataIn);
    EXPECT_EQ(r.length, 8) << "the first 8 bytes carry bMaxPacketSize0";
    EXPECT_FALSE(r.zero_length_packet) << "the host asked for exactly 8";
}

TEST_F(UsbControl, ZeroLengthPacketWhenShortAndMultipleOfMaxPacket) {
    // §5.5.3: a data stage shorter than wLength ends with a short packet;
    // if its length is a multiple of wMaxPacketSize that is a ZLP.
    ControlReply r = h.setup(req(kVendorIn, 0x10, 64, 0, 100));
    ASSERT_EQ(r.kind, Kind::kDataIn);
    EXPECT_EQ(r.length, 64);
    EXPECT_TRUE(r.zero_length_packet);
    r = h.setup(req(kVendorIn, 0x10, 64, 0, 64));
    EXPECT_FALSE(r.zero_length_packet) << "exactly wLength: no ZLP";
    r = h.setup(req(kVendorIn, 0x10, 100, 0, 80));
    EXPECT_EQ(r.length, 80) << "a vendor reply is truncated to wLength too";
    r = h.setup(req(kVendorIn, 0x10, 0, 0, 10));
    EXPECT_EQ(r.length, 0);
    EXPECT_TRUE(r.zero_length_packet) << "an empty reply to a non-zero wLength is a ZLP";
}

TEST_F(UsbControl, ConfigurationStates) {
    EXPECT_EQ(h.setup(req(kOutDevice, 9, 1, 0, 0)).kind, Kind::kStall) << "SET_CONFIGURATION in Default";
    EXPECT_EQ(h.setup(req(kInDevice, 8, 0, 0, 1)).kind, Kind::kStall) << "GET_CONFIGURATION in Default";
    address(3);
    EXPECT_EQ(in(h.setup(req(kInDevice, 8, 0, 0, 1))), std::vector<uint8_t>{0});
    EXPECT_EQ(h.setup(req(kOutDevice, 9, 2, 0, 0)).kind, Kind::kStall) << "no configuration 2";
    EXPECT_EQ(h.setup(req(kOutDevice, 9, 1, 0, 0)).kind, Kind::kStatusIn);
    EXPECT_EQ(hw.configure_calls_on, 1);
    EXPECT_EQ(h.setup(req(kOutDevice, 9, 0, 0, 0)).kind, Kind::kStatusIn);
    EXPECT_EQ(h.state(), DeviceState::kAddress);
    EXPECT_FALSE(hw.configured);
    EXPECT_EQ(hw.configure_calls_off, 1);
}

TEST_F(UsbControl, EndpointHaltFeature) {
    EXPECT_EQ(h.setup(req(kInEndpoint, 0, 0, 0x81, 2)).kind, Kind::kStall) << "endpoints in Default";
    configure();
    EXPECT_EQ(in(h.setup(req(kInEndpoint, 0, 0, 0x81, 2))), (std::vector<uint8_t>{0, 0}));
    EXPECT_EQ(h.setup(req(kOutEndpoint, 3, kFeatureEndpointHalt, 0x81, 0)).kind, Kind::kStatusIn);
    EXPECT_TRUE(hw.stalled_in);
    EXPECT_EQ(in(h.setup(req(kInEndpoint, 0, 0, 0x81, 2))), (std::vector<uint8_t>{1, 0}));
    EXPECT_EQ(h.setup(req(kOutEndpoint, 1, kFeatureEndpointHalt, 0x81, 0)).kind, Kind::kStatusIn);
    EXPECT_FALSE(hw.stalled_in);
    EXPECT_EQ(h.setup(req(kInEndpoint, 0, 0, 0x82, 2)).kind, Kind::kStall) << "no EP2";
    EXPECT_EQ(h.setup(req(kOutEndpoint, 3, kFeatureEndpointHalt, 0x02, 0)).kind, Kind::kStall);
    EXPECT_EQ(in(h.setup(req(kInEndpoint, 0, 0, 0x00, 2))), (std::vector<uint8_t>{0, 0})) << "EP0";
}

TEST_F(UsbControl, EndpointOneOnlyWhenConfigured) {
    address(4);
    EXPECT_EQ(h.setup(req(kInEndpoint, 0, 0, 0x01, 2)).kind, Kind::kStall)
        << "in Address state only EP0 may be addressed (§9.4.5)";
    EXPECT_EQ(in(h.setup(req(kInEndpoint, 0, 0, 0x80, 2))), (std::vector<uint8_t>{0, 0}));
}

TEST_F(UsbControl, DeviceStatusAndUnsupportedFeatures) {
    address(2);
    EXPECT_EQ(in(h.setup(req(kInDevice, 0, 0, 0, 2))), (std::vector<uint8_t>{0, 0}))
        << "bus powered, remote wakeup off";
    EXPECT_EQ(h.setup(req(kOutDevice, 3, kFeatureDeviceRemoteWakeup, 0, 0)).kind, Kind::kStall)
        << "remote wakeup is not offered in bmAttributes";
    EXPECT_EQ(h.setup(req(kOutDevice, 3, kFeatureTestMode, 0x0100, 0)).kind, Kind::kStall)
        << "test mode is for high-speed devices";
    EXPECT_EQ(h.setup(req(kInDevice, 0, 0, 0, 4)).kind, Kind::kStall) << "GET_STATUS wLength must be 2";
}

TEST_F(UsbControl, Interface) {
    EXPECT_EQ(h.setup(req(kInInterface, 10, 0, 0, 1)).kind, Kind::kStall) << "GET_INTERFACE before configured";
    configure();
    EXPECT_EQ(in(h.setup(req(kInInterface, 10, 0, 0, 1))), std::vector<uint8_t>{0});
    EXPECT_EQ(in(h.setup(req(kInInterface, 0, 0, 0, 2))), (std::vector<uint8_t>{0, 0}));
    EXPECT_EQ(h.setup(req(kOutInterface, 11, 0, 0, 0)).kind, Kind::kStatusIn);
    EXPECT_EQ(h.setup(req(kOutInterface, 11, 1, 0, 0)).kind, Kind::kStall) << "only alternate setting 0";
    EXPECT_EQ(h.setup(req(kInInterface, 10, 0, 1, 1)).kind, Kind::kStall) << "only interface 0";
}

TEST_F(UsbControl, BusResetDeconfigures) {
    configure();
    h.bus_reset();
    EXPECT_EQ(h.state(), DeviceState::kDefault);
    EXPECT_EQ(h.address(), 0);
    EXPECT_EQ(h.configuration(), 0);
    EXPECT_FALSE(hw.configured);
}

TEST_F(UsbControl, ClassAndUnknownRequestsStall) {
    configure();
    EXPECT_EQ(h.setup(req(kClassIn, 0xFE, 0, 0, 1)).kind, Kind::kStall) << "no class requests";
    EXPECT_EQ(h.setup(req(kOutDevice, 7, 0x0100, 0, 18)).kind, Kind::kStall) << "SET_DESCRIPTOR";
    EXPECT_EQ(h.setup(req(kInEndpoint, 12, 0, 0x81, 2)).kind, Kind::kStall) << "SYNCH_FRAME (isochronous only)";
    EXPECT_EQ(h.setup(req(0xC1, 0x10, 4, 0, 4)).kind, Kind::kStall) << "vendor requests to the device only";
    EXPECT_EQ(h.setup(req(kVendorIn, 0x55, 0, 0, 4)).kind, Kind::kStall) << "unknown vendor request";
}

TEST_F(UsbControl, VendorOutDataStage) {
    configure();
    const ControlReply r = h.setup(req(kVendorOut, 0x11, 0, 0, 5));
    ASSERT_EQ(r.kind, Kind::kDataOut);
    EXPECT_EQ(r.length, 5);
    const uint8_t payload[5] = {1, 2, 3, 4, 5};
    h.data_out_done(payload, 5);
    EXPECT_EQ(hw.vendor_out, (std::vector<uint8_t>{1, 2, 3, 4, 5}));
}

// A serial known only at run time (the STM32's unique ID, read at start-up):
// the handler is built with a placeholder, set_serial() before the bus
// connects, and GET_DESCRIPTOR(string 3) returns that text in UTF-16LE.
TEST(UsbControlSerial, SerialSetAtRunTimeIsTheOneEnumerated) {
    FakeHw hw;
    ControlHandler<FakeHw> h{hw, DeviceIdentity{}, "piezoloop", "piezo servo", "", AddressTiming::kAtSetup};
    // The text lives in a buffer filled after construction, as on the board.
    UniqueIdSerial serial{};
    serial = serial_from_unique_id({0x00300035u, 0x33335117u, 0x33353634u});
    h.set_serial(serial.data());
    // The device descriptor names string 3 as iSerialNumber.
    ControlReply r = h.setup(req(kInDevice, 6, 0x0100, 0, 18));
    ASSERT_EQ(r.kind, Kind::kDataIn);
    EXPECT_EQ(r.data[16], kStringSerial);
    r = h.setup(req(kInDevice, 6, 0x0300 | kStringSerial, kLangIdEnglishUs, 255));
    ASSERT_EQ(r.kind, Kind::kDataIn);
    const char* want = "003000353333511733353634";
    std::vector<uint8_t> expected{50, 3};
    for (const char* c = want; *c != '\0'; ++c) {
        expected.push_back(static_cast<uint8_t>(*c));
        expected.push_back(0);
    }
    EXPECT_EQ(std::vector<uint8_t>(r.data, r.data + r.length), expected);
    EXPECT_FALSE(r.zero_length_packet) << "50 bytes < wLength 255, not a multiple of 64";
    // Linux reads the header first (wLength 2 / 255 varies): truncation holds.
    r = h.setup(req(kInDevice, 6, 0x0300 | kStringSerial, kLangIdEnglishUs, 2));
    ASSERT_EQ(r.kind, Kind::kDataIn);
    EXPECT_EQ(r.length, 2);
    EXPECT_EQ(r.data[0], 50);
    // The other strings are untouched.
    r = h.setup(req(kInDevice, 6, 0x0301, kLangIdEnglishUs, 255));
    EXPECT_EQ(r.length, 2 + 2 * std::strlen("piezoloop"));
}

TEST(UsbControlSerial, PlaceholderIsAnEmptyStringNotAStall) {
    // Before set_serial the placeholder "" is a valid (empty) descriptor:
    // nothing undefined if a host asked early.
    FakeHw hw;
    ControlHandler<FakeHw> h{hw, DeviceIdentity{}, "piezoloop", "piezo servo", "", AddressTiming::kAtSetup};
    const ControlReply r = h.setup(req(kInDevice, 6, 0x0303, kLangIdEnglishUs, 255));
    ASSERT_EQ(r.kind, Kind::kDataIn);
    EXPECT_EQ(std::vector<uint8_t>(r.data, r.data + r.length), (std::vector<uint8_t>{2, 3}));
}
