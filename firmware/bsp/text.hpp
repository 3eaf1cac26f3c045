// One console line built in a fixed buffer: no printf (which would pull in
// newlib's stdio, heap and syscalls), no allocation. Integers in decimal,
// raw bit patterns in hex; floats are printed as their IEEE bits, which is
// also what determinism checks compare.
#pragma once

#include <bit>
#include <cstddef>
#include <cstdint>

#include "bsp/bsp.hpp"

namespace piezoloop::bsp {

class TextLine {
public:
    static constexpr std::size_t kCapacity = 240;

    TextLine& str(const char* s) {
        while (*s != '\0') put(*s++);
        return *this;
    }
    TextLine& dec(int64_t v) {
        // Magnitude as unsigned so INT64_MIN does not overflow.
        uint64_t m = v < 0 ? uint64_t{0} - static_cast<uint64_t>(v) : static_cast<uint64_t>(v);
        if (v < 0) put('-');
        return udec(m);
    }
    TextLine& udec(uint64_t m) {
        char digits[20];
        std::size_t n = 0;
        do {
            digits[n++] = static_cast<char>('0' + m % 10u);
            m /= 10u;
        } while (m != 0u);
        while (n > 0) put(digits[--n]);
        return *this;
    }
    TextLine& hex(uint32_t v) {
        static constexpr char kDigits[] = "0123456789abcdef";
        str("0x");
        for (int shift = 28; shift >= 0; shift -= 4) put(kDigits[(v >> shift) & 0xFu]);
        return *this;
    }
    TextLine& hex64(uint64_t v) {
        static constexpr char kDigits[] = "0123456789abcdef";
        str("0x");
        for (int shift = 60; shift >= 0; shift -= 4) put(kDigits[(v >> shift) & 0xFu]);
        return *this;
    }
    TextLine& bits(float f) { return hex(std::bit_cast<uint32_t>(f)); }
    // " key=" prefix helpers keep the call sites short.
    TextLine& key(const char* k) { return put(' ').str(k).put('='); }

    TextLine& put(char c) {
        if (length_ < kCapacity) buffer_[length_++] = c;
        return *this;
    }
    // Writes the line and a newline to the console, then empties the buffer.
    void flush() {
        buffer_[length_++] = '\n';  // the buffer keeps one byte for it
        console_write(buffer_, length_);
        length_ = 0;
    }

private:
    char buffer_[kCapacity + 1] = {};
    std::size_t length_ = 0;
};

}  // namespace piezoloop::bsp
