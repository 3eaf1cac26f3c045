// USB descriptors of the firmware (firmware/usb/descriptors.hpp) against the
// layouts of the USB 2.0 specification, chapter 9 (Tables 9-8, 9-10, 9-12,
// 9-13, 9-15, 9-16). Byte-exact: a descriptor is either right or it is not,
// so there is no tolerance anywhere.
#include <gtest/gtest.h>

#include <array>
#include <cstdint>
#include <cstdio>
#include <cstring>
#include <random>
#include <string>
#include <vector>

#include "usb/descriptors.hpp"
#include "usb/serial_number.hpp"

using namespace piezoloop::usb;

TEST(UsbDescriptors, DeviceDescriptorMatchesTable9_8) {
    DeviceIdentity id;
    id.vendor_id = 0x1209;
    id.product_id = 0xABCD;
    id.device_release_bcd = 0x0123;
    const auto d = device_descriptor(id);
    const std::array<uint8_t, 18> want = {
        0x12,        // bLength 18
        0x01,        // DEVICE
        0x00, 0x02,  // bcdUSB 2.00, little endian
        0x00, 0x00, 0x00,  // class defined per interface
        64,          // bMaxPacketSize0
        0x09, 0x12,  // idVendor 0x1209
        0xCD, 0xAB,  // idProduct 0xABCD
        0x23, 0x01,  // bcdDevice 1.23
        1, 2, 3,     // iManufacturer, iProduct, iSerialNumber
        1};          // bNumConfigurations
    EXPECT_EQ(d, want);
}

TEST(UsbDescriptors, ConfigurationIsOneVendorInterfaceWithTwoBulkEndpoints) {
    const auto c = configuration_descriptor(DeviceIdentity{});
    // Configuration (Table 9-10).
    ASSERT_EQ(c[0], 9);
    EXPECT_EQ(c[1], 2);
    EXPECT_EQ(c[2] | (c[3] << 8), 9 + 9 + 7 + 7) << "wTotalLength covers all descriptors returned";
    EXPECT_EQ(c[4], 1) << "bNumInterfaces";
    EXPECT_EQ(c[5], 1) << "bConfigurationValue (0 would mean unconfigured)";
    EXPECT_EQ(c[7] & 0x80, 0x80) << "bmAttributes bit 7 is reserved and must be set";
    EXPECT_EQ(c[7] & 0x20, 0) << "no remote wakeup offered";
    EXPECT_EQ(c[8], 50) << "100 mA in 2 mA units";
    // Walk the chain: every descriptor's bLength, ending exactly at wTotalLength.
    std::vector<std::pair<int, int>> chain;  // (type, offset)
    std::size_t at = 0;
    while (at < c.size()) {
        ASSERT_GE(c[at], 2);
        chain.emplace_back(c[at + 1], static_cast<int>(at));
        at += c[at];
    }
    EXPECT_EQ(at, c.size());
    ASSERT_EQ(chain.size(), 4u);
    EXPECT_EQ(chain[1].first, 4);
    EXPECT_EQ(chain[2].first, 5);
    EXPECT_EQ(chain[3].first, 5);
    // Interface (Table 9-12): number 0, alternate 0, two endpoints, vendor class 0xFF.
    const std::size_t i = static_cast<std::size_t>(chain[1].second);
    EXPECT_EQ(c[i + 2], 0);
    EXPECT_EQ(c[i + 3], 0);
    EXPECT_EQ(c[i + 4], 2);
    EXPECT_EQ(c[i + 5], 0xFF);
    // Endpoints (Table 9-13): EP1 OUT and EP1 IN, bulk (bmAttributes 2), 64 bytes.
    const std::size_t e1 = static_cast<std::size_t>(chain[2].second), e2 = static_cast<std::size_t>(chain[3].second);
    EXPECT_EQ(c[e1 + 2], 0x01);
    EXPECT_EQ(c[e2 + 2], 0x81);
    for (std::size_t e : {e1, e2}) {
        EXPECT_EQ(c[e], 7);
        EXPECT_EQ(c[e + 3], 0x02);
        EXPECT_EQ(c[e + 4] | (c[e + 5] << 8), 64) << "full-speed bulk maximum";
        EXPECT_EQ(c[e + 6], 0) << "bInterval is ignored for full-speed bulk";
    }
}

TEST(UsbDescriptors, StringZeroListsUsEnglish) {
    const auto s = langid_descriptor();
    EXPECT_EQ(s, (std::array<uint8_t, 4>{4, 3, 0x09, 0x04}));
}

TEST(UsbDescriptors, StringsAreUtf16LittleEndian) {
    uint8_t out[64] = {};
    ASSERT_EQ(string_descriptor("Ab1", out, sizeof out), 8u);
    const uint8_t want[8] = {8, 3, 'A', 0, 'b', 0, '1', 0};
    for (int i = 0; i < 8; ++i) EXPECT_EQ(out[i], want[i]) << i;
    EXPECT_EQ(string_descriptor("", out, sizeof out), 2u) << "an empty string is just the header";
}

TEST(UsbDescriptors, StringsRefuseWhatCannotBeEncoded) {
    uint8_t out[300] = {};
    EXPECT_EQ(string_descriptor("\xC3\xA9", out, sizeof out), 0u) << "not 7-bit ASCII";
    EXPECT_EQ(string_descriptor("abcd", out, 9), 0u) << "needs 10 bytes";
    const std::string max(126, 'x'), over(127, 'x');
    EXPECT_EQ(string_descriptor(max.c_str(), out, sizeof out), 254u) << "bLength is one byte: 2 + 2 * 126";
    EXPECT_EQ(string_descriptor(over.c_str(), out, sizeof out), 0u);
}

// The serial number from the 96-bit unique device ID (firmware/usb/serial_number.hpp).
// Reference: the C library's `%08X%08X%08X` of the three words, which is
// the documented format; exact text, no tolerance.
TEST(UsbSerialNumber, IsTheThreeWordsInHexInAddressOrder) {
    // A UID as a debugger reads it (three words at the base address).
    EXPECT_STREQ(serial_from_unique_id({0x00300035u, 0x33335117u, 0x33353634u}).data(), "003000353333511733353634");
    EXPECT_STREQ(serial_from_unique_id({0u, 0u, 0u}).data(), "000000000000000000000000");
    EXPECT_STREQ(serial_from_unique_id({0xFFFFFFFFu, 0xABCDEF01u, 0x0000000Au}).data(), "FFFFFFFFABCDEF010000000A");
}

TEST(UsbSerialNumber, MatchesPrintfForRandomIds) {
    std::mt19937 rng(20261122);  // seeded: reproducible
    for (int k = 0; k < 2000; ++k) {
        const std::array<uint32_t, 3> w{static_cast<uint32_t>(rng()), static_cast<uint32_t>(rng()),
                                         static_cast<uint32_t>(rng())};
        char want[32];
        std::snprintf(want, sizeof want, "%08X%08X%08X", static_cast<unsigned>(w[0]), static_cast<unsigned>(w[1]),
                      static_cast<unsigned>(w[2]));
        const UniqueIdSerial got = serial_from_unique_id(w);
        ASSERT_STREQ(got.data(), want) << k;
        ASSERT_EQ(std::strlen(got.data()), kUniqueIdSerialLength);
    }
}

TEST(UsbSerialNumber, EveryBitOfTheIdShowsAndTheTextIsAValidStringDescriptor) {
    const std::array<uint32_t, 3> base{0x12345678u, 0x9ABCDEF0u, 0x0F1E2D3Cu};
    const std::string text = serial_from_unique_id(base).data();
    for (int bit = 0; bit < 96; ++bit) {
        std::array<uint32_t, 3> w = base;
        w[static_cast<std::size_t>(bit / 32)] ^= 1u << (bit % 32);
        EXPECT_NE(text, std::string(serial_from_unique_id(w).data())) << "bit " << bit;
    }
    for (const char c : text) EXPECT_TRUE((c >= '0' && c <= '9') || (c >= 'A' && c <= 'F')) << c;
    uint8_t out[64] = {};
    ASSERT_EQ(string_descriptor(text.c_str(), out, sizeof out), 2u + 2u * 24u);
    EXPECT_EQ(out[0], 50);
    EXPECT_EQ(out[1], 3);
    for (std::size_t i = 0; i < 24; ++i) {
        EXPECT_EQ(out[2 + 2 * i], static_cast<uint8_t>(text[i]));
        EXPECT_EQ(out[3 + 2 * i], 0);
    }
}

// Usable at compile time as well (e.g. a fixed test identity).
static_assert(serial_from_unique_id({0xDEADBEEFu, 1u, 0x80000000u})[0] == 'D');
static_assert(serial_from_unique_id({0xDEADBEEFu, 1u, 0x80000000u})[15] == '1');
static_assert(serial_from_unique_id({0xDEADBEEFu, 1u, 0x80000000u})[16] == '8');
static_assert(serial_from_unique_id({0xDEADBEEFu, 1u, 0x80000000u})[24] == '\0');
