// Chapter-9 request handling of the piezoloop USB device on endpoint 0,
// independent of the device controller: a board's driver hands over each
// SETUP packet and carries out the reply (data stage, status stage or
// STALL); this class decides what the USB 2.0 specification requires.
//
// Device states (USB 2.0 §9.1, Figure 9-1), as far as the host can see them
// through requests: Default (after bus reset, address 0) -> Address (after
// SET_ADDRESS(n != 0)) -> Configured (after SET_CONFIGURATION(1)); back via
// SET_CONFIGURATION(0), SET_ADDRESS(0) and bus reset.
//
// Requests (§9.4), and what is a "Request Error" (STALL, §9.2.7):
//   GET_STATUS        device: 2 bytes, bus powered, no remote wakeup;
//                     interface 0: 2 zero bytes (Configured only);
//                     endpoint: halt bit (EP0 always; EP1 only Configured)
//   CLEAR/SET_FEATURE ENDPOINT_HALT on EP1 IN/OUT (Configured); clearing
//                     also resets the data toggle (driver). Remote wakeup
//                     and test mode are not supported: STALL
//   SET_ADDRESS       1..127 or 0, no data stage; invalid in Configured
//   GET_DESCRIPTOR    device, configuration 0, strings 0..3 (LANGID 0x0409
//                     or 0 for string 0); device_qualifier and
//                     other_speed_configuration: STALL (a full-speed-only
//                     device must, §9.6.2); the reply is truncated to
//                     wLength and ended with a zero-length packet when it is
//                     shorter than wLength and a multiple of the EP0 size
//                     (§5.5.3)
//   GET/SET_CONFIGURATION  0 or 1; SET in Default: STALL
//   GET/SET_INTERFACE interface 0, alternate setting 0 only (Configured)
//   SET_DESCRIPTOR, SYNCH_FRAME, class requests: STALL
//   vendor requests   handed to Hw::vendor_setup (device recipient only)
//
// Hw must provide:
//   void set_address(uint8_t address);
//   void configure_endpoints(bool on);           // open / close EP1 IN and OUT
//   void set_endpoint_stall(uint8_t ep, bool stall);  // ep with direction bit
//   bool endpoint_stalled(uint8_t ep) const;
//   ControlReply vendor_setup(const SetupPacket&, uint8_t* buffer, std::size_t capacity);
//   void vendor_data_out(const SetupPacket&, const uint8_t* data, std::size_t length);
#pragma once

#include <array>
#include <cstddef>
#include <cstdint>

#include "piezoloop/usb/descriptors.hpp"
#include "piezoloop/usb/setup.hpp"

namespace piezoloop::usb {

enum class DeviceState : uint8_t { kDefault, kAddress, kConfigured };

struct ControlReply {
    enum class Kind : uint8_t {
        kStall,     // request error: STALL the data/status stage
        kDataIn,    // send data[0..length) then expect the host's OUT status
        kDataOut,   // receive `length` bytes, then send the IN status (ZLP)
        kStatusIn,  // no data stage: send the IN status (ZLP)
    };
    Kind kind = Kind::kStall;
    const uint8_t* data = nullptr;
    uint16_t length = 0;
    bool zero_length_packet = false;  // kDataIn: end with a ZLP

    static ControlReply stall() { return {}; }
    static ControlReply status() { return {Kind::kStatusIn, nullptr, 0, false}; }
};

// When the device takes its new address. The status stage of SET_ADDRESS
// still runs at the old address (§9.4.6); controllers differ in how that is
// achieved: the Synopsys DWC2 (STM32 OTG) wants the address in DCFG at once
// and completes the status stage itself at the old one, others must be
// given the address only after the status stage.
enum class AddressTiming : uint8_t { kAtSetup, kAfterStatus };

template <class Hw>
class ControlHandler {
public:
    ControlHandler(Hw& hw, const DeviceIdentity& id, const char* manufacturer, const char* product,
                   const char* serial, AddressTiming timing)
        : hw_(hw),
          device_(device_descriptor(id)),
          configuration_(configuration_descriptor(id)),
          strings_{manufacturer, product, serial},
          timing_(timing) {}

    // The serial number string (index 3) when it is known only at run time
    // (a board's unique device ID): call before the device connects to the
    // bus, so the host never sees another one. Strings are not copied: the
    // text must outlive the handler. The descriptor is built from it at each
    // GET_DESCRIPTOR.
    void set_serial(const char* serial) { strings_[2] = serial; }

    // USB reset: back to Default, address 0, endpoints closed.
    void bus_reset() {
        if (state_ == DeviceState::kConfigured) hw_.configure_endpoints(false);
        state_ = DeviceState::kDefault;
        address_ = 0;
        configuration_value_ = 0;
        pending_ = Pending::kNone;
    }

    ControlReply setup(const SetupPacket& s) {
        pending_ = Pending::kNone;
        last_ = s;
        switch (s.type()) {
            case RequestType::kStandard: return standard(s);
            case RequestType::kVendor:
                if (s.recipient() != Recipient::kDevice) return ControlReply::stall();
                return limit(hw_.vendor_setup(s, buffer_.data(), buffer_.size()), s);
            default: return ControlReply::stall();
        }
    }

    // The status stage of the last request has completed.
    void status_stage_done() {
        if (pending_ == Pending::kAddress) {
            address_ = pending_address_;
            if (timing_ == AddressTiming::kAfterStatus) hw_.set_address(address_);
            state_ = address_ == 0 ? DeviceState::kDefault : DeviceState::kAddress;
        }
        pending_ = Pending::kNone;
    }

    // The OUT data stage of the last request arrived (vendor requests).
    void data_out_done(const uint8_t* data, std::size_t length) {
        if (last_.type() == RequestType::kVendor) hw_.vendor_data_out(last_, data, length);
    }

    DeviceState state() const { return state_; }
    uint8_t address() const { return address_; }
    uint8_t configuration() const { return configuration_value_; }

private:
    enum class Pending : uint8_t { kNone, kAddress };

    ControlReply standard(const SetupPacket& s) {
        using R = StandardRequest;
        const bool configured = state_ == DeviceState::kConfigured;
        if (s.is(R::kGetDescriptor) && s.device_to_host() && s.recipient() == Recipient::kDevice)
            return get_descriptor(s);
        if (s.is(R::kSetAddress) && !s.device_to_host() && s.recipient() == Recipient::kDevice) {
            if (s.wValue > 127 || s.wIndex != 0 || s.wLength != 0 || configured) return ControlReply::stall();
            pending_ = Pending::kAddress;
            pending_address_ = static_cast<uint8_t>(s.wValue);
            if (timing_ == AddressTiming::kAtSetup) hw_.set_address(pending_address_);
            return ControlReply::status();
        }
        if (s.is(R::kGetConfiguration) && s.device_to_host() && s.recipient() == Recipient::kDevice) {
            if (s.wValue != 0 || s.wIndex != 0 || s.wLength != 1 || state_ == DeviceState::kDefault)
                return ControlReply::stall();
            buffer_[0] = configuration_value_;
            return data_in(buffer_.data(), 1, s);
        }
        if (s.is(R::kSetConfiguration) && !s.device_to_host() && s.recipient() == Recipient::kDevice) {
            const uint16_t v = s.wValue;
            if (state_ == DeviceState::kDefault || s.wIndex != 0 || s.wLength != 0 ||
                (v != 0 && v != kConfigurationValue))
                return ControlReply::stall();
            if (v == 0) {
                if (configured) hw_.configure_endpoints(false);
                configuration_value_ = 0;
                state_ = DeviceState::kAddress;
            } else {
                // (Re)selecting the configuration resets the endpoints'
                // halt and toggle state (§9.1.1.5).
                if (configured) hw_.configure_endpoints(false);
                hw_.configure_endpoints(true);
                configuration_value_ = kConfigurationValue;
                state_ = DeviceState::kConfigured;
            }
            return ControlReply::status();
        }
        if (s.is(R::kGetStatus) && s.device_to_host()) return get_status(s);
        if ((s.is(R::kClearFeature) || s.is(R::kSetFeature)) && !s.device_to_host()) return feature(s);
        if (s.is(R::kGetInterface) && s.device_to_host() && s.recipient() == Recipient::kInterface) {
            if (!configured || s.wIndex != kInterfaceNumber || s.wValue != 0 || s.wLength != 1)
                return ControlReply::stall();
            buffer_[0] = 0;
            return data_in(buffer_.data(), 1, s);
        }
        if (s.is(R::kSetInterface) && !s.device_to_host() && s.recipient() == Recipient::kInterface) {
            if (!configured || s.wIndex != kInterfaceNumber || s.wValue != 0 || s.wLength != 0)
                return ControlReply::stall();
            // Alternate setting 0 re-selected: endpoint state resets.
            hw_.set_endpoint_stall(kBulkOutEndpoint, false);
            hw_.set_endpoint_stall(kBulkInEndpoint, false);
            return ControlReply::status();
        }
        return ControlReply::stall();
    }

    ControlReply get_descriptor(const SetupPacket& s) {
        const auto type = static_cast<DescriptorType>(s.wValue >> 8);
        const uint8_t index = static_cast<uint8_t>(s.wValue & 0xFFu);
        switch (type) {
            case DescriptorType::kDevice:
                if (index != 0 || s.wIndex != 0) return ControlReply::stall();
                return data_in(device_.data(), device_.size(), s);
            case DescriptorType::kConfiguration:
                if (index != 0 || s.wIndex != 0) return ControlReply::stall();
                return data_in(configuration_.data(), configuration_.size(), s);
            case DescriptorType::kString: {
                if (index == kStringLangIds) {
                    static constexpr auto kLangIds = langid_descriptor();
                    return data_in(kLangIds.data(), kLangIds.size(), s);
                }
                if (index > kStringSerial || s.wIndex != kLangIdEnglishUs) return ControlReply::stall();
                const std::size_t n =
                    string_descriptor(strings_[index - 1u], buffer_.data(), buffer_.size());
                if (n == 0) return ControlReply::stall();
                return data_in(buffer_.data(), n, s);
            }
            default: return ControlReply::stall();  // incl. device_qualifier: full speed only
        }
    }

    ControlReply get_status(const SetupPacket& s) {
        if (s.wValue != 0 || s.wLength != 2) return ControlReply::stall();
        buffer_[0] = 0;
        buffer_[1] = 0;
        switch (s.recipient()) {
            case Recipient::kDevice:
                if (s.wIndex != 0 || state_ == DeviceState::kDefault) return ControlReply::stall();
                break;  // bus powered (bit 0 = 0), remote wakeup disabled (bit 1 = 0)
            case Recipient::kInterface:
                if (state_ != DeviceState::kConfigured || s.wIndex != kInterfaceNumber) return ControlReply::stall();
                break;
            case Recipient::kEndpoint: {
                const uint8_t ep = static_cast<uint8_t>(s.wIndex & 0xFFu);
                if (!endpoint_addressable(ep) || (s.wIndex >> 8) != 0) return ControlReply::stall();
                buffer_[0] = hw_.endpoint_stalled(ep) ? 1 : 0;
                break;
            }
            default: return ControlReply::stall();
        }
        return data_in(buffer_.data(), 2, s);
    }

    ControlReply feature(const SetupPacket& s) {
        const bool set = s.bRequest == static_cast<uint8_t>(StandardRequest::kSetFeature);
        if (s.wLength != 0) return ControlReply::stall();
        if (s.recipient() == Recipient::kEndpoint && s.wValue == kFeatureEndpointHalt) {
            const uint8_t ep = static_cast<uint8_t>(s.wIndex & 0xFFu);
            if (!endpoint_addressable(ep) || (s.wIndex >> 8) != 0) return ControlReply::stall();
            if ((ep & 0x7Fu) == 0) return ControlReply::status();  // EP0 halt: nothing to keep
            hw_.set_endpoint_stall(ep, set);
            return ControlReply::status();
        }
        // DEVICE_REMOTE_WAKEUP (not offered in bmAttributes), TEST_MODE
        // (high speed only) and interface features (none defined).
        return ControlReply::stall();
    }

    // EP0 in Address and Configured; EP1 IN/OUT only when Configured.
    bool endpoint_addressable(uint8_t ep) const {
        if (state_ == DeviceState::kDefault) return false;
        if (ep == 0x00 || ep == 0x80) return true;
        return state_ == DeviceState::kConfigured && (ep == kBulkOutEndpoint || ep == kBulkInEndpoint);
    }

    ControlReply data_in(const uint8_t* data, std::size_t size, const SetupPacket& s) const {
        ControlReply r;
        r.kind = ControlReply::Kind::kDataIn;
        r.data = data;
        r.length = static_cast<uint16_t>(size < s.wLength ? size : s.wLength);
        r.zero_length_packet = r.length < s.wLength && r.length % kEp0MaxPacket == 0;
        return r;
    }

    // A vendor reply is bounded by the request and the buffer like ours.
    ControlReply limit(ControlReply r, const SetupPacket& s) const {
        if (r.kind == ControlReply::Kind::kDataIn) {
            if (!s.device_to_host() || r.data == nullptr) return ControlReply::stall();
            return data_in(r.data, r.length, s);
        }
        if (r.kind == ControlReply::Kind::kDataOut &&
            (s.device_to_host() || r.length != s.wLength || r.length > buffer_.size()))
            return ControlReply::stall();
        return r;
    }

    Hw& hw_;
    std::array<uint8_t, 18> device_;
    std::array<uint8_t, kConfigurationTotalLength> configuration_;
    const char* strings_[3];
    AddressTiming timing_;
    std::array<uint8_t, 256> buffer_{};
    DeviceState state_ = DeviceState::kDefault;
    uint8_t address_ = 0;
    uint8_t pending_address_ = 0;
    uint8_t configuration_value_ = 0;
    Pending pending_ = Pending::kNone;
    SetupPacket last_{};
};

}  // namespace piezoloop::usb
