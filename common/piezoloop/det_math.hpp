// Deterministic elementary functions for configure-time work in the core.
//
// libm differs between glibc (host) and newlib (boards), so a coefficient
// computed with std::exp on the host could differ by an ulp from the one the
// board computes, and the float path would no longer be bit-identical. These
// use only IEEE +, -, *, / on double, which every target rounds the same way.
// They are not meant for the tick.
#pragma once

#include <bit>
#include <cstdint>

namespace piezoloop {

// e^x for |x| <= ~700: x = k ln2 + r with |r| <= ln2/2, e^r by a Taylor series
// to 1e-17, then scaled by 2^k. Accurate to a few ulp.
constexpr double det_exp(double x) {
    constexpr double kLn2 = 0.69314718055994530942;
    // ln 2 split in two (Cody–Waite) so k * kLn2Hi is exact for |k| < 2^11.
    constexpr double kLn2Hi = 6.93147180369123816490e-01;
    constexpr double kLn2Lo = 1.90821492927058770002e-10;
    if (!(x == x)) return x;
    if (x > 709.0) return __builtin_huge_val();
    if (x < -745.0) return 0.0;
    const double kf = x / kLn2;
    const int k = static_cast<int>(kf >= 0.0 ? kf + 0.5 : kf - 0.5);
    const double r = (x - k * kLn2Hi) - k * kLn2Lo;
    double term = 1.0, sum = 1.0;
    for (int i = 1; i < 24; ++i) {
        term *= r / i;
        sum += term;
    }
    double scale = 1.0;
    if (k >= 0) {
        for (int i = 0; i < k; ++i) scale *= 2.0;
    } else {
        for (int i = 0; i < -k; ++i) scale *= 0.5;
    }
    return sum * scale;
}

// Bit tests rather than x == x, so they hold even under -ffinite-math-only.
constexpr bool is_finite(float x) {
    return (std::bit_cast<uint32_t>(x) & 0x7f800000u) != 0x7f800000u;
}
constexpr bool is_finite(double x) {
    return (std::bit_cast<uint64_t>(x) & 0x7ff0000000000000ull) != 0x7ff0000000000000ull;
}

}  // namespace piezoloop
