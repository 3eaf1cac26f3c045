// The USB serial number of a board from its 96-bit unique device ID, so that
// two boards on one host can be told apart (`--device usb:SERIAL`).
//
// Text: 24 upper-case hexadecimal digits, the three 32-bit words of the ID
// in address order (word 0 = UID[31:0] first), each written most
// significant digit first -- what `%08X%08X%08X` of the three words gives,
// and what a debugger shows reading the three words (e.g. OpenOCD
// `mdw 0x1FF1E800 3` on the STM32H7). Only 0-9 and A-F: valid in a USB
// string descriptor and in a shell argument, and no two IDs give one text.
#pragma once

#include <array>
#include <cstddef>
#include <cstdint>

namespace piezoloop::usb {

inline constexpr std::size_t kUniqueIdWords = 3;
inline constexpr std::size_t kUniqueIdSerialLength = 8 * kUniqueIdWords;  // 24 characters
// The text and its terminating NUL.
using UniqueIdSerial = std::array<char, kUniqueIdSerialLength + 1>;

constexpr UniqueIdSerial serial_from_unique_id(const std::array<uint32_t, kUniqueIdWords>& words) {
    constexpr char kDigits[] = "0123456789ABCDEF";
    UniqueIdSerial text{};
    std::size_t n = 0;
    for (const uint32_t w : words)
        for (int shift = 28; shift >= 0; shift -= 4) text[n++] = kDigits[(w >> shift) & 0xFu];
    text[n] = '\0';
    return text;
}

}  // namespace piezoloop::usb
