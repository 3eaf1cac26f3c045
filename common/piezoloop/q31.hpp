// Q31 fixed-point sample: a signed 32-bit integer read as value / 2^31, so the
// range is [-1, 1 - 2^-31]. Physical signals are normalised by a full scale
// before they enter the Q31 pipeline (see ScaleQ31 in scale.hpp).
//
// Every operation saturates: a wrapped sample would flip the sign of the piezo
// command, which is the one thing a servo must never do.
//
// Coefficients larger than one use a block exponent ("coefficient shift"): a
// real coefficient c is stored as a Q31 mantissa m with c = m * 2^(e - 31).
// All coefficients of a block share e, chosen so that the sum of |m| is at
// most 2^31; a multiply-accumulate of Q31 samples with those mantissas then
// fits in int64 without any overflow check (|sum m*x| <= 2^31 * 2^31 = 2^62).
#pragma once

#include <compare>
#include <cstdint>
#include <limits>

namespace piezoloop {

class Q31 {
public:
    static constexpr int32_t kMaxRaw = std::numeric_limits<int32_t>::max();
    static constexpr int32_t kMinRaw = std::numeric_limits<int32_t>::min();
    static constexpr float kOneF = 2147483648.0f;  // 2^31

    constexpr Q31() = default;
    static constexpr Q31 from_raw(int32_t raw) { Q31 q; q.raw_ = raw; return q; }

    // Saturating conversion; NaN maps to zero (the safe command).
    static constexpr Q31 from_float(float x) {
        if (!(x == x)) return from_raw(0);
        const float scaled = x * kOneF;
        if (scaled >= kOneF) return from_raw(kMaxRaw);
        if (scaled <= -kOneF) return from_raw(kMinRaw);
        // Round half away from zero, done by hand so it is constexpr and
        // needs no libm on the target.
        const float r = scaled >= 0.0f ? scaled + 0.5f : scaled - 0.5f;
        return from_raw(static_cast<int32_t>(r));
    }
    static constexpr Q31 from_double(double x) {
        if (!(x == x)) return from_raw(0);
        const double scaled = x * 2147483648.0;
        if (scaled >= 2147483647.0) return from_raw(kMaxRaw);
        if (scaled <= -2147483648.0) return from_raw(kMinRaw);
        const double r = scaled >= 0.0 ? scaled + 0.5 : scaled - 0.5;
        return from_raw(static_cast<int32_t>(r));
    }

    constexpr int32_t raw() const { return raw_; }
    constexpr float to_float() const { return static_cast<float>(raw_) / kOneF; }
    constexpr double to_double() const { return static_cast<double>(raw_) / 2147483648.0; }

    static constexpr Q31 max_value() { return from_raw(kMaxRaw); }
    static constexpr Q31 min_value() { return from_raw(kMinRaw); }

    friend constexpr bool operator==(Q31 a, Q31 b) { return a.raw_ == b.raw_; }
    friend constexpr auto operator<=>(Q31 a, Q31 b) { return a.raw_ <=> b.raw_; }

    friend constexpr Q31 operator+(Q31 a, Q31 b) { return saturate(int64_t{a.raw_} + b.raw_); }
    friend constexpr Q31 operator-(Q31 a, Q31 b) { return saturate(int64_t{a.raw_} - b.raw_); }
    constexpr Q31 operator-() const { return saturate(-int64_t{raw_}); }
    constexpr Q31& operator+=(Q31 b) { return *this = *this + b; }
    constexpr Q31& operator-=(Q31 b) { return *this = *this - b; }

    // Rounding multiply: (a*b + 2^30) >> 31. Only (-1)*(-1) can overflow; it
    // saturates to the largest value.
    friend constexpr Q31 operator*(Q31 a, Q31 b) {
        const int64_t p = int64_t{a.raw_} * b.raw_;
        return saturate((p + (int64_t{1} << 30)) >> 31);
    }

    static constexpr Q31 saturate(int64_t v) {
        if (v > kMaxRaw) return from_raw(kMaxRaw);
        if (v < kMinRaw) return from_raw(kMinRaw);
        return from_raw(static_cast<int32_t>(v));
    }

private:
    int32_t raw_ = 0;
};

constexpr Q31 max(Q31 a, Q31 b) { return a < b ? b : a; }
constexpr Q31 min(Q31 a, Q31 b) { return b < a ? b : a; }

// ---- block-exponent coefficients ------------------------------------------

// Smallest exponent e in [-31, 31] with sum|c| <= 2^e (so mantissas |m| sum to
// at most 2^31). Returns 31 if even that is not enough; callers validate
// coefficient ranges before quantising.
constexpr int block_exponent(const double* c, int n) {
    double l1 = 0.0;
    for (int i = 0; i < n; ++i) l1 += c[i] < 0.0 ? -c[i] : c[i];
    int e = -31;
    double bound = 1.0 / 2147483648.0;  // 2^-31
    while (e < 31 && l1 > bound) { bound *= 2.0; ++e; }
    return e;
}

// Mantissa of c for block exponent e: round(c * 2^(31-e)), saturated.
constexpr int32_t quantize_mantissa(double c, int e) {
    double scale = 2147483648.0;  // 2^31
    for (int i = 0; i < e; ++i) scale *= 0.5;
    for (int i = 0; i > e; --i) scale *= 2.0;
    return Q31::from_double(c * scale / 2147483648.0).raw();
}

// Arithmetic shift right by s (0..62) with round-half-up, on the int64
// accumulator of products mantissa*sample (a Q62 value times 2^-e).
constexpr int64_t round_shift_right(int64_t acc, int s) {
    if (s <= 0) return acc;
    return (acc + (int64_t{1} << (s - 1))) >> s;
}

// Accumulator of sum m_i * x_i for block exponent e  ->  Q31 sample.
// The value is acc * 2^(e - 62); as Q31 that is acc >> (31 - e).
constexpr Q31 q31_from_accumulator(int64_t acc, int e) {
    const int s = 31 - e;
    if (s >= 0) return Q31::saturate(round_shift_right(acc, s));
    // e > 31 never happens (block_exponent caps at 31).
    return Q31::saturate(acc);
}

}  // namespace piezoloop
