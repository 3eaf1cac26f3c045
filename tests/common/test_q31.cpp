// Q31 arithmetic against exact integer/double references.
#include <gtest/gtest.h>

#include <cmath>
#include <random>

#include "piezoloop/q31.hpp"

using piezoloop::Q31;

TEST(Q31, ConversionSaturatesAndMapsNaNToZero) {
    EXPECT_EQ(Q31::from_float(1.0f).raw(), Q31::kMaxRaw);
    EXPECT_EQ(Q31::from_float(5.0f).raw(), Q31::kMaxRaw);
    EXPECT_EQ(Q31::from_float(-1.0f).raw(), Q31::kMinRaw);
    EXPECT_EQ(Q31::from_float(-7.0f).raw(), Q31::kMinRaw);
    EXPECT_EQ(Q31::from_float(INFINITY).raw(), Q31::kMaxRaw);
    EXPECT_EQ(Q31::from_float(-INFINITY).raw(), Q31::kMinRaw);
    EXPECT_EQ(Q31::from_float(NAN).raw(), 0);
    EXPECT_EQ(Q31::from_float(0.5f).raw(), 1 << 30);
    EXPECT_EQ(Q31::from_double(-0.25).raw(), -(1 << 29));
    EXPECT_EQ(Q31::from_double(0.5).to_double(), 0.5);
}

TEST(Q31, AddSubSaturateNeverWrap) {
    const Q31 big = Q31::from_double(0.75);
    EXPECT_EQ((big + big).raw(), Q31::kMaxRaw);
    EXPECT_EQ((-big - big).raw(), Q31::kMinRaw);
    EXPECT_EQ((-Q31::min_value()).raw(), Q31::kMaxRaw);
    EXPECT_EQ((Q31::min_value() - Q31::from_raw(1)).raw(), Q31::kMinRaw);
}

TEST(Q31, RandomOpsMatchExactIntegerReference) {
    std::mt19937_64 rng(1234);
    std::uniform_int_distribution<int32_t> d(Q31::kMinRaw, Q31::kMaxRaw);
    for (int i = 0; i < 200000; ++i) {
        const int32_t a = d(rng), b = d(rng);
        const int64_t sum = std::clamp<int64_t>(int64_t{a} + b, Q31::kMinRaw, Q31::kMaxRaw);
        const int64_t dif = std::clamp<int64_t>(int64_t{a} - b, Q31::kMinRaw, Q31::kMaxRaw);
        EXPECT_EQ((Q31::from_raw(a) + Q31::from_raw(b)).raw(), sum);
        EXPECT_EQ((Q31::from_raw(a) - Q31::from_raw(b)).raw(), dif);
        // Rounding multiply: exact product / 2^31 rounded half up, within
        // half an LSB of the real product (checked in long double).
        const long double exact = static_cast<long double>(a) * b / 2147483648.0L;
        const int32_t p = (Q31::from_raw(a) * Q31::from_raw(b)).raw();
        EXPECT_LE(std::fabs(static_cast<long double>(p) - exact), 0.5L);
    }
    EXPECT_EQ((Q31::min_value() * Q31::min_value()).raw(), Q31::kMaxRaw);
}

TEST(Q31, BlockExponentKeepsAccumulatorInRange) {
    const double c[] = {2.55, -1.57, 0.57, 1.3};  // L1 = 5.99 -> e = 3
    const int e = piezoloop::block_exponent(c, 4);
    EXPECT_EQ(e, 3);
    int64_t mant_l1 = 0;
    for (double v : c) {
        const int32_t m = piezoloop::quantize_mantissa(v, e);
        mant_l1 += std::llabs(m);
        // Quantisation error is at most half a mantissa LSB, 2^(e-32).
        EXPECT_LE(std::fabs(m * std::ldexp(1.0, e - 31) - v), std::ldexp(1.0, e - 32));
    }
    EXPECT_LE(mant_l1, int64_t{1} << 31);
    const double small[] = {6.4e-5, -3.0e-5};
    EXPECT_EQ(piezoloop::block_exponent(small, 2), -13);  // 9.4e-5 <= 2^-13
}

TEST(Q31, AccumulatorToQ31RoundsAndSaturates) {
    // 0.5 * 0.5 with e = 0: acc = 2^30 * 2^30 = 2^60 -> 0.25 = 2^29.
    EXPECT_EQ(piezoloop::q31_from_accumulator(int64_t{1} << 60, 0).raw(), 1 << 29);
    // Coefficient 4 (e = 2, mantissa 2^31-1) times 0.5 saturates.
    const int64_t acc = int64_t{Q31::kMaxRaw} * (1 << 30);
    EXPECT_EQ(piezoloop::q31_from_accumulator(acc, 2).raw(), Q31::kMaxRaw);
}
