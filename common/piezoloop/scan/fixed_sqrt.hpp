// Square root of a 64-bit integer without libm, identical on every target,
// cheap enough for the tick (a count of leading zeros, a table read, one
// multiply): the CLV spiral's angle grows as sqrt(t).
//
// X is normalised by an even shift to m in [2^62, 2^64), so m / 2^64 lies
// in [1/4, 1); sqrt there comes from a table of 768 segments of width 2^-10
// (769 points, Q31, computed at compile time by Newton's iteration in
// double and rounded), linearly interpolated, and is shifted back.
// Error: interpolation h^2/8 max|f''| = 2^-20 / 8 * 2 = 2.4e-7 of the
// normalised root (>= 1/2), table rounding 0.5 LSB, so the result is within
// 5e-7 relative (plus the final truncation, < 1) of sqrt(X). The result is
// monotonic in X (the table is, and interpolation keeps it so).
// Table: 769 * 4 bytes = 3.0 KiB of flash.
#pragma once

#include <array>
#include <bit>
#include <cstdint>

namespace piezoloop {

namespace fixed_sqrt_detail {

inline constexpr int kSegments = 768;  // over [1/4, 1), width 2^-10

constexpr double newton_sqrt(double x) {  // x in [1/4, 1]
    double y = 1.0;
    for (int i = 0; i < 40; ++i) y = 0.5 * (y + x / y);
    return y;
}

constexpr std::array<uint32_t, kSegments + 1> make_table() {
    std::array<uint32_t, kSegments + 1> t{};
    for (int j = 0; j <= kSegments; ++j) {
        const double v = newton_sqrt(static_cast<double>(256 + j) / 1024.0) * 2147483648.0 + 0.5;
        t[static_cast<std::size_t>(j)] = static_cast<uint32_t>(v);  // <= 2^31
    }
    return t;
}

}  // namespace fixed_sqrt_detail

// sqrt((256 + j) / 1024) for j = 0..768, Q31.
inline constexpr std::array<uint32_t, fixed_sqrt_detail::kSegments + 1> kSqrtTableQ31 =
    fixed_sqrt_detail::make_table();

// sqrt(X), within 5e-7 relative plus 1 (see above); at most 2^32.
constexpr uint64_t fixed_sqrt(uint64_t x) {
    if (x == 0) return 0;
    const int e = std::countl_zero(x) & ~1;                          // even shift
    const uint64_t m = x << e;                                        // [2^62, 2^64)
    const uint32_t i = static_cast<uint32_t>(m >> 54) - 256u;         // segment, 0..767
    const uint64_t frac = static_cast<uint32_t>(m >> 22);             // position in it, 32 bits
    const uint64_t a = kSqrtTableQ31[i], b = kSqrtTableQ31[i + 1];
    const uint64_t v = a + (((b - a) * frac) >> 32);                  // sqrt(m / 2^64), Q31
    // sqrt(x) = sqrt(m / 2^64) * 2^32 / 2^(e/2) = v * 2^(1 - e/2).
    const int s = e / 2 - 1;
    return s < 0 ? v << 1 : v >> s;
}

}  // namespace piezoloop
