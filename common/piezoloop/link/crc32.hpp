// CRC-32 of IEEE 802.3 (also zlib, PNG): reflected, polynomial 0x04C11DB7
// (0xEDB88320 reflected), initial value and final XOR 0xFFFFFFFF. Check value
// of "123456789" is 0xCBF43926. A 256-entry table computed at compile time
// (1 KiB of flash, one lookup per byte): the link checks every byte it
// receives, so the byte-at-a-time form is worth its table.
#pragma once

#include <array>
#include <cstddef>
#include <cstdint>
#include <span>

namespace piezoloop::link {

inline constexpr uint32_t kCrc32Polynomial = 0xEDB88320u;  // reflected 0x04C11DB7

namespace crc_detail {
constexpr std::array<uint32_t, 256> make_table() {
    std::array<uint32_t, 256> t{};
    for (uint32_t i = 0; i < 256; ++i) {
        uint32_t c = i;
        for (int k = 0; k < 8; ++k) c = (c & 1u) ? (c >> 1) ^ kCrc32Polynomial : c >> 1;
        t[i] = c;
    }
    return t;
}
inline constexpr std::array<uint32_t, 256> kTable = make_table();
}  // namespace crc_detail

// Incremental form: state starts at 0xFFFFFFFF, the result is state ^ 0xFFFFFFFF.
constexpr uint32_t crc32_update(uint32_t state, std::span<const uint8_t> data) {
    for (const uint8_t b : data) state = crc_detail::kTable[(state ^ b) & 0xffu] ^ (state >> 8);
    return state;
}

constexpr uint32_t crc32(std::span<const uint8_t> data) {
    return crc32_update(0xFFFFFFFFu, data) ^ 0xFFFFFFFFu;
}

}  // namespace piezoloop::link
