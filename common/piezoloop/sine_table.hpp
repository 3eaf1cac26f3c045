// Sine of a 32-bit phase without libm, identical on every target.
//
// A quarter-wave table of sin(x), x in [0, pi/2], 1024 segments (1025 points
// plus one guard), computed at compile time from the Taylor series in double
// and rounded to Q31. The other three quarters follow by symmetry, so the
// full cycle has 4096 segments. Linear interpolation between points.
//
// Error against the exact sine, in units of full scale (1.0):
//   interpolation  <= h^2/8 * max|sin''| = (pi/2/1024)^2 / 8 = 2.94e-7
//   table rounding <= 0.5 LSB, interpolation rounding <= 0.5 LSB (2^-31 each)
// so |sine_q31(p) / 2^31 - sin(2 pi p / 2^32)| <= 2.95e-7 (0.3 ppm of the
// amplitude: 12 pm on a 40 µm sine, far below a 16-bit DAC step).
// Table size: 1026 * 4 bytes = 4.1 KiB of flash.
#pragma once

#include <array>
#include <cstdint>

namespace piezoloop {

namespace sine_detail {

inline constexpr double kPi = 3.141592653589793238462643383279502884;
inline constexpr int kQuarterBits = 10;  // 1024 segments per quarter wave
inline constexpr int kQuarterSegments = 1 << kQuarterBits;

// Taylor series, |x| <= pi/2: the terms fall below 1e-20 long before n = 30,
// and the double rounding (~1e-16) is far below half a Q31 LSB (2.3e-10).
constexpr double sin_series(double x) {
    const double x2 = x * x;
    double term = x;
    double sum = x;
    for (int n = 1; n < 30; ++n) {
        term *= -x2 / static_cast<double>((2 * n) * (2 * n + 1));
        sum += term;
    }
    return sum;
}

constexpr int32_t round_to_q31(double v) {  // v in [0, 1]
    const double s = v * 2147483648.0 + 0.5;
    if (s >= 2147483647.0) return 2147483647;
    return static_cast<int32_t>(s);
}

constexpr std::array<int32_t, kQuarterSegments + 2> make_quarter_table() {
    std::array<int32_t, kQuarterSegments + 2> t{};
    for (int i = 0; i <= kQuarterSegments; ++i) {
        t[static_cast<std::size_t>(i)] =
            round_to_q31(sin_series(kPi / 2.0 * static_cast<double>(i) / kQuarterSegments));
    }
    // Guard: read (times a zero fraction) when the mirrored position is exactly pi/2.
    t[kQuarterSegments + 1] = t[kQuarterSegments - 1];
    return t;
}

}  // namespace sine_detail

// sin(2 pi i / 4096) for i = 0..1024, Q31 (plus a guard entry).
inline constexpr std::array<int32_t, sine_detail::kQuarterSegments + 2> kSineQuarterQ31 =
    sine_detail::make_quarter_table();

// sin(2 pi phase / 2^32) as a Q31 raw value, error <= 2.95e-7 (see above).
constexpr int32_t sine_q31(uint32_t phase) {
    constexpr int kFracBits = 30 - sine_detail::kQuarterBits;  // 20
    const uint32_t quadrant = phase >> 30;
    uint32_t x = phase & 0x3fffffffu;                  // position in the quarter, 30 bits
    if (quadrant & 1u) x = 0x40000000u - x;            // mirror: sin(pi/2 + t) = sin(pi/2 - t)
    const uint32_t i = x >> kFracBits;                 // 0..1024
    const int64_t frac = static_cast<int64_t>(x & ((1u << kFracBits) - 1u));
    const int64_t a = kSineQuarterQ31[i];
    const int64_t b = kSineQuarterQ31[i + 1];
    const int64_t v = a + (((b - a) * frac + (int64_t{1} << (kFracBits - 1))) >> kFracBits);
    return static_cast<int32_t>(quadrant & 2u ? -v : v);  // |v| < 2^31: no overflow
}

}  // namespace piezoloop
