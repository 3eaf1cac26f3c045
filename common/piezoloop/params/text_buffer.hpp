// A fixed-capacity, always zero-terminated text, for error texts the core
// composes at run time (field paths, allowed ranges) without heap or libc.
// Appending beyond the capacity cuts the text.
#pragma once

#include <array>
#include <cstddef>
#include <cstdint>

namespace piezoloop::params {

template <std::size_t N>
class TextBuffer {
    static_assert(N >= 2);

public:
    constexpr const char* c_str() const { return buf_.data(); }
    constexpr std::size_t size() const { return n_; }
    constexpr void clear() { truncate(0); }
    constexpr void truncate(std::size_t n) {
        if (n < n_) n_ = n;
        buf_[n_] = '\0';
    }

    constexpr void append(const char* s) {
        for (; s != nullptr && *s != '\0'; ++s) put(*s);
    }
    constexpr void append_int(long long v) {
        if (v < 0) {
            put('-');
            append_digits(static_cast<unsigned long long>(-(v + 1)) + 1u, 1);
        } else {
            append_digits(static_cast<unsigned long long>(v), 1);
        }
    }
    // Up to five significant digits: whole numbers below 1e10 as integers,
    // others in [1e-3, 1e9) as decimals, the rest as d.dddde+XX.
    constexpr void append_number(double v) {
        if (v != v) return append("nan");
        if (v < 0.0) {
            put('-');
            v = -v;
        }
        if (v > 1.7976931348623157e308) return append("inf");
        if (v < 1e10 && static_cast<double>(static_cast<unsigned long long>(v)) == v)
            return append_digits(static_cast<unsigned long long>(v), 1);
        int exp10 = 0;
        double m = v;
        if (m != 0.0) {
            while (m >= 10.0) { m /= 10.0; ++exp10; }
            while (m < 1.0) { m *= 10.0; --exp10; }
        }
        // m in [1, 10): five significant digits, rounded.
        unsigned long long digits = static_cast<unsigned long long>(m * 10000.0 + 0.5);
        if (digits >= 100000u) { digits /= 10u; ++exp10; }
        if (exp10 >= -3 && exp10 < 9) {
            // Decimal: the digits with the point placed by the exponent.
            const int point = exp10 + 1;  // digits before the point (<= 0: leading zeros)
            char d[5] = {};
            for (int i = 4; i >= 0; --i) { d[i] = static_cast<char>('0' + digits % 10u); digits /= 10u; }
            int last = 4;
            while (last > 0 && last >= point && d[last] == '0') --last;
            if (point <= 0) {
                append("0.");
                for (int i = point; i < 0; ++i) put('0');
                for (int i = 0; i <= last; ++i) put(d[i]);
            } else {
                for (int i = 0; i < point; ++i) put(i < 5 ? d[i] : '0');
                if (last >= point) {
                    put('.');
                    for (int i = point; i <= last; ++i) put(d[i]);
                }
            }
            return;
        }
        char d[5] = {};
        for (int i = 4; i >= 0; --i) { d[i] = static_cast<char>('0' + digits % 10u); digits /= 10u; }
        int last = 4;
        while (last > 0 && d[last] == '0') --last;
        put(d[0]);
        if (last > 0) {
            put('.');
            for (int i = 1; i <= last; ++i) put(d[i]);
        }
        put('e');
        put(exp10 < 0 ? '-' : '+');
        const int e = exp10 < 0 ? -exp10 : exp10;
        if (e < 10) put('0');
        append_digits(static_cast<unsigned long long>(e), 1);
    }

private:
    constexpr void put(char c) {
        if (n_ + 1 < N) buf_[n_++] = c;
        buf_[n_] = '\0';
    }
    constexpr void append_digits(unsigned long long v, int min_digits) {
        char tmp[24] = {};
        int k = 0;
        do {
            tmp[k++] = static_cast<char>('0' + v % 10u);
            v /= 10u;
        } while (v != 0 || k < min_digits);
        while (k > 0) put(tmp[--k]);
    }

    std::array<char, N> buf_{};
    std::size_t n_ = 0;
};

}  // namespace piezoloop::params
