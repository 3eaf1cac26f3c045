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
    static constexpr std::size_t kCapacity = 1024;  // a self-test JSON line fits (three axes: ~900)

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
    // Decimal with a fixed number of decimals (0..9), rounded half away
    // from zero; "null" for NaN or beyond +-9.2e18 / 10^decimals. Plain
    // double arithmetic, the same on every target.
    TextLine& fixed(double v, int decimals) {
        double scale = 1.0;
        for (int i = 0; i < decimals; ++i) scale *= 10.0;
        const double s = v * scale;
        if (!(s == s) || s >= 9.2e18 || s <= -9.2e18) return str("null");
        const int64_t q = static_cast<int64_t>(s >= 0.0 ? s + 0.5 : s - 0.5);
        const uint64_t m = q < 0 ? uint64_t{0} - static_cast<uint64_t>(q) : static_cast<uint64_t>(q);
        const uint64_t unit = static_cast<uint64_t>(scale);
        if (q < 0) put('-');
        udec(m / unit);
        if (decimals > 0) {
            put('.');
            uint64_t frac = m % unit;
            for (uint64_t d = unit / 10u; d > 0u; d /= 10u) {
                put(static_cast<char>('0' + frac / d));
                frac %= d;
            }
        }
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
