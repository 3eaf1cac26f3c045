// Output limiter: the piezo's last line of defence.
//
// References are exact: the hard limits and the per-sample slew bound
// (slew_max / rate) are checked in long double, where every product and
// difference used below is exact or rounded far below the tested margins.
// Property tests use a seeded mt19937_64.
#include <gtest/gtest.h>

#include <bit>
#include <cmath>
#include <cstdint>
#include <limits>
#include <random>
#include <vector>

#include "piezoloop/limits.hpp"

using piezoloop::HardLimits;
using piezoloop::LimitsConfig;
using piezoloop::OutputLimiter;
using piezoloop::Q31;
using piezoloop::SignalScale;
using piezoloop::TripReason;

namespace {

constexpr float kRate = 100000.0f;
// A P-752-like stage behind a -30..130 V amplifier: the piezo takes -20..120 V.
constexpr HardLimits kHard{-20.0f, 120.0f, 2.0e5f};  // 2 V per sample at 100 kHz
static_assert(piezoloop::validate(kHard).ok(), "board constants are checked at compile time");

bool same_config(const LimitsConfig& a, const LimitsConfig& b) {
    return std::bit_cast<uint32_t>(a.u_min_V) == std::bit_cast<uint32_t>(b.u_min_V) &&
           std::bit_cast<uint32_t>(a.u_max_V) == std::bit_cast<uint32_t>(b.u_max_V) &&
           std::bit_cast<uint32_t>(a.slew_V_per_s) == std::bit_cast<uint32_t>(b.slew_V_per_s) &&
           std::bit_cast<uint32_t>(a.saturation_trip_s) == std::bit_cast<uint32_t>(b.saturation_trip_s);
}

// The documented rules, written independently of validate().
bool obeys_rules(const LimitsConfig& c, const HardLimits& h) {
    return std::isfinite(c.u_min_V) && std::isfinite(c.u_max_V) && std::isfinite(c.slew_V_per_s) &&
           std::isfinite(c.saturation_trip_s) && c.u_min_V >= h.u_min_V && c.u_max_V <= h.u_max_V &&
           c.u_min_V < c.u_max_V && c.slew_V_per_s > 0.0f && c.slew_V_per_s <= h.slew_max_V_per_s &&
           c.saturation_trip_s >= 0.0f;
}

// Hostile random values: NaN, ±Inf, denormals, huge, random bit patterns,
// and plausible values in and around the hard range.
class Hostile {
public:
    explicit Hostile(uint64_t seed) : rng_(seed) {}
    float any_float() {
        const int k = pick(100);
        if (k < 10) return std::numeric_limits<float>::quiet_NaN();
        if (k < 13) return -std::numeric_limits<float>::quiet_NaN();
        if (k < 18) return std::numeric_limits<float>::infinity();
        if (k < 23) return -std::numeric_limits<float>::infinity();
        if (k < 33) {  // denormal, either sign
            const uint32_t m = static_cast<uint32_t>(rng_()) & 0x007fffffu;
            return std::bit_cast<float>(m | (pick(2) ? 0x80000000u : 0u));
        }
        if (k < 43) return (pick(2) ? 1.0f : -1.0f) * std::ldexp(1.0f, 60 + pick(68)) * uni(1.0, 1.99);
        if (k < 53) return std::bit_cast<float>(static_cast<uint32_t>(rng_()));  // anything
        if (k < 56) return pick(2) ? 0.0f : -0.0f;
        return static_cast<float>(uni(-200.0, 250.0));
    }
    float volt() {
        const int k = pick(100);
        if (k < 15) return any_float();
        if (k < 60) return static_cast<float>(uni(kHard.u_min_V, kHard.u_max_V));
        return static_cast<float>(uni(-1000.0, 1000.0));
    }
    float slew() {
        const int k = pick(100);
        if (k < 15) return any_float();
        if (k < 20) return pick(2) ? 0.0f : -1.0f;
        // At the hard slew: the rounding of last + step matters only there.
        if (k < 35) return kHard.slew_max_V_per_s;
        return static_cast<float>(std::pow(10.0, uni(-3.0, 9.0)));  // 1e-3 .. 1e9 V/s
    }
    LimitsConfig config() {
        LimitsConfig c;
        c.u_min_V = volt();
        c.u_max_V = volt();
        if (pick(2) && c.u_min_V > c.u_max_V) std::swap(c.u_min_V, c.u_max_V);
        c.slew_V_per_s = slew();
        const int k = pick(100);
        c.saturation_trip_s = k < 70 ? 0.0f : (k < 90 ? static_cast<float>(uni(1e-5, 1e-2)) : any_float());
        return c;
    }
    int pick(int n) { return static_cast<int>(rng_() % static_cast<uint64_t>(n)); }
    double uni(double a, double b) { return std::uniform_real_distribution<double>(a, b)(rng_); }
    std::mt19937_64& rng() { return rng_; }

private:
    std::mt19937_64 rng_;
};

LimitsConfig good_config() { return {0.0f, 100.0f, 1.0e5f, 0.0f}; }

}  // namespace

// ---- validation ------------------------------------------------------------

TEST(Limits, ValidateNamesTheOffendingField) {
    const float nan = std::numeric_limits<float>::quiet_NaN();
    struct Case { LimitsConfig c; const char* field; };
    const Case cases[] = {
        {{nan, 100.0f, 1e5f, 0.0f}, "u_min_V"},
        {{-21.0f, 100.0f, 1e5f, 0.0f}, "u_min_V"},
        {{0.0f, 121.0f, 1e5f, 0.0f}, "u_max_V"},
        {{0.0f, INFINITY, 1e5f, 0.0f}, "u_max_V"},
        {{50.0f, 40.0f, 1e5f, 0.0f}, "u_max_V"},
        {{50.0f, 50.0f, 1e5f, 0.0f}, "u_max_V"},
        {{0.0f, 100.0f, 0.0f, 0.0f}, "slew_V_per_s"},
        {{0.0f, 100.0f, -5.0f, 0.0f}, "slew_V_per_s"},
        {{0.0f, 100.0f, 3e5f, 0.0f}, "slew_V_per_s"},
        {{0.0f, 100.0f, nan, 0.0f}, "slew_V_per_s"},
        {{0.0f, 100.0f, 1e5f, -1.0f}, "saturation_trip_s"},
        {{0.0f, 100.0f, 1e5f, nan}, "saturation_trip_s"},
    };
    for (const Case& k : cases) {
        const auto s = piezoloop::validate(k.c, kHard);
        ASSERT_FALSE(s.ok());
        EXPECT_STREQ(s.field, k.field);
        EXPECT_NE(s.message, nullptr);
    }
    EXPECT_TRUE(piezoloop::validate(good_config(), kHard).ok());
    EXPECT_TRUE(piezoloop::validate(LimitsConfig{-20.0f, 120.0f, 2e5f, 1.0f}, kHard).ok());  // edges allowed

    EXPECT_FALSE(piezoloop::validate(HardLimits{10.0f, 10.0f, 1.0f}).ok());
    EXPECT_FALSE(piezoloop::validate(HardLimits{0.0f, NAN, 1.0f}).ok());
    EXPECT_FALSE(piezoloop::validate(HardLimits{0.0f, 1.0f, 0.0f}).ok());
    EXPECT_FALSE(piezoloop::validate(HardLimits{0.0f, 2e6f, 1.0f}).ok());
}

TEST(Limits, RejectedConfigurationKeepsTheOldOne) {
    OutputLimiter<float> lim(kHard, kRate);
    ASSERT_TRUE(lim.configure(good_config()).ok());
    const LimitsConfig bad{0.0f, 500.0f, 1e5f, 0.0f};
    const auto s = lim.configure(bad);
    EXPECT_STREQ(s.field, "u_max_V");
    EXPECT_TRUE(same_config(lim.config(), good_config()));
    for (int i = 0; i < 200; ++i) lim.apply(300.0f);
    EXPECT_EQ(lim.output(), 100.0f);  // still the old u_max
}

TEST(Limits, SlewBelowTheFloatResolutionIsRejected) {
    // ulp(120 V) = 7.6e-6 V: at 100 kHz a 0.5 V/s slew is a 5e-6 V step that
    // would round away to nothing near the top of the range.
    OutputLimiter<float> lim(kHard, kRate);
    const auto s = lim.configure({0.0f, 100.0f, 0.5f, 0.0f});
    EXPECT_STREQ(s.field, "slew_V_per_s");
    EXPECT_TRUE(lim.configure({0.0f, 100.0f, 5.0f, 0.0f}).ok());  // 5e-5 V per sample: fine
    // Q31 with 150 V full scale: one LSB is 7e-8 V; 1e-3 V/s is 1e-8 V per sample.
    OutputLimiter<Q31> q(kHard, kRate, SignalScale{150.0f});
    EXPECT_STREQ(q.configure({0.0f, 100.0f, 1e-3f, 0.0f}).field, "slew_V_per_s");
}

TEST(Limits, InvalidHardLimitsTripPermanently) {
    OutputLimiter<float> lim(HardLimits{5.0f, -5.0f, 1e5f}, kRate);
    EXPECT_FALSE(lim.hard_status().ok());
    EXPECT_EQ(lim.trip_reason(), TripReason::kInvalidHardLimits);
    EXPECT_FALSE(lim.configure(good_config()).ok());
    EXPECT_FALSE(lim.clear_trip());
    EXPECT_EQ(lim.apply(50.0f), 0.0f);

    OutputLimiter<float> bad_rate(kHard, 0.0f);
    EXPECT_STREQ(bad_rate.hard_status().field, "sample_rate_Hz");
    // Q31: a hard range entirely above the full scale cannot be represented.
    OutputLimiter<Q31> q(HardLimits{200.0f, 300.0f, 1e5f}, kRate, SignalScale{150.0f});
    EXPECT_FALSE(q.hard_status().ok());
    EXPECT_EQ(q.apply(Q31::from_raw(123456)).raw(), 0);
}

// ---- deterministic behaviour -----------------------------------------------

TEST(Limits, ClampsToTheConfiguredRangeAndCounts) {
    OutputLimiter<float> lim(kHard, kRate);
    ASSERT_TRUE(lim.configure({0.0f, 100.0f, 2e5f, 0.0f}).ok());
    EXPECT_FALSE(lim.tripped());
    // 2 V per sample (minus one ulp of 120 V for the exact hard bound): 150 V is
    // clamped to 100 V, reached after ceil(100 / 2) + 1 samples at most.
    float y = 0.0f;
    for (int i = 0; i < 60; ++i) y = lim.apply(150.0f);
    EXPECT_EQ(y, 100.0f);
    EXPECT_EQ(lim.clamped_samples(), 60u);
    for (int i = 0; i < 60; ++i) y = lim.apply(-5.0f);
    EXPECT_EQ(y, 0.0f);
    EXPECT_EQ(lim.clamped_samples(), 120u);
    y = lim.apply(1.25f);
    EXPECT_EQ(y, 1.25f);  // inside the range and within one step: passed through exactly
    EXPECT_EQ(lim.clamped_samples(), 120u);
}

TEST(Limits, SlewRateLimitsEachStep) {
    OutputLimiter<float> lim(kHard, kRate);
    ASSERT_TRUE(lim.configure({-20.0f, 120.0f, 1.0e4f, 0.0f}).ok());  // 0.1 V per sample
    const double step = 1.0e4 / 100000.0;
    // The per-sample step is the float at or below 0.1 V: 0.1 * (1 - 2^-23) <= step <= 0.1.
    EXPECT_LE(static_cast<double>(lim.step_per_sample()), step);
    EXPECT_GE(static_cast<double>(lim.step_per_sample()), step * (1.0 - 0x1p-23));
    float prev = lim.output();
    EXPECT_EQ(prev, 0.0f);  // starts at the safe output, the clamp of 0 V
    int n = 0;
    while (prev != 10.0f && n < 1000) {
        const float y = lim.apply(10.0f);
        // Each step is the per-sample step up to the rounding of the sum,
        // half an ulp of the output (<= 4.8e-7 V below 16 V).
        EXPECT_LE(std::fabs(static_cast<double>(y) - prev), step + 4.8e-7);
        EXPECT_GT(y, prev);
        prev = y;
        ++n;
    }
    // 10 V at 0.1 V per sample: 100 samples, 101 if the rounded steps fall short.
    EXPECT_GE(n, 100);
    EXPECT_LE(n, 101);
    EXPECT_EQ(lim.slew_limited_samples(), static_cast<uint32_t>(n - 1));
    // Downward the same.
    for (int i = 0; i < 50; ++i) prev = lim.apply(-20.0f);
    EXPECT_NEAR(prev, 10.0f - 50 * step, 50 * 4.8e-7 + 50 * step * 0x1p-23);
}

TEST(Limits, NarrowedRangeIsEnteredAtTheSlewRate) {
    OutputLimiter<float> lim(kHard, kRate);
    ASSERT_TRUE(lim.configure({-20.0f, 120.0f, 2e5f, 0.0f}).ok());
    float y = 0.0f;
    for (int i = 0; i < 100; ++i) y = lim.apply(110.0f);
    ASSERT_EQ(y, 110.0f);
    ASSERT_TRUE(lim.configure({0.0f, 50.0f, 1e5f, 0.0f}).ok());  // 1 V per sample
    const float next = lim.apply(110.0f);
    EXPECT_LT(110.0f - next, 1.0f + 1e-5f);  // no jump to 50 V
    EXPECT_GT(110.0f - next, 0.99f);
    for (int i = 0; i < 100; ++i) y = lim.apply(110.0f);
    EXPECT_EQ(y, 50.0f);
}

TEST(Limits, NonFiniteInputTripsAndRampsToTheSafeValueUntilCleared) {
    OutputLimiter<float> lim(kHard, kRate);
    ASSERT_TRUE(lim.configure({10.0f, 100.0f, 1e5f, 0.0f}).ok());  // safe = clamp(0) = 10 V
    EXPECT_EQ(lim.safe_output(), 10.0f);
    float y = 0.0f;
    for (int i = 0; i < 200; ++i) y = lim.apply(80.0f);
    ASSERT_EQ(y, 80.0f);

    y = lim.apply(std::numeric_limits<float>::quiet_NaN());
    EXPECT_TRUE(lim.tripped());
    EXPECT_EQ(lim.trip_reason(), TripReason::kNonFinite);
    EXPECT_EQ(lim.nonfinite_samples(), 1u);
    EXPECT_NEAR(y, 79.0f, 1e-5f);  // one 1 V step towards the safe value, no jump
    // Valid inputs do not release the trip; the output ramps down to 10 V and stays.
    for (int i = 0; i < 100; ++i) y = lim.apply(80.0f);
    EXPECT_EQ(y, 10.0f);
    EXPECT_TRUE(lim.tripped());
    // Another cause does not overwrite the first.
    lim.apply(std::numeric_limits<float>::infinity());
    lim.trip();
    EXPECT_EQ(lim.trip_reason(), TripReason::kNonFinite);
    EXPECT_EQ(lim.nonfinite_samples(), 2u);

    EXPECT_TRUE(lim.clear_trip());
    EXPECT_FALSE(lim.tripped());
    y = lim.apply(80.0f);
    EXPECT_NEAR(y, 11.0f, 1e-5f);  // back to following the command, at the slew rate
}

TEST(Limits, NotConfiguredBehavesAsTripped) {
    OutputLimiter<float> lim(kHard, kRate);
    EXPECT_TRUE(lim.tripped());
    EXPECT_EQ(lim.trip_reason(), TripReason::kNotConfigured);
    EXPECT_FALSE(lim.clear_trip());
    lim.preset_output(50.0f);  // the DAC happens to sit at 50 V at start-up
    float y = 0.0f;
    for (int i = 0; i < 10; ++i) y = lim.apply(100.0f);
    // Ramps from 50 V to 0 V at the hard step (2 V minus one ulp(120 V) per sample).
    EXPECT_NEAR(y, 30.0f, 10 * 1e-5);
    ASSERT_TRUE(lim.configure(good_config()).ok());
    EXPECT_FALSE(lim.tripped());
}

TEST(Limits, SustainedSaturationTrips) {
    OutputLimiter<float> lim(kHard, kRate);
    // 1 ms at 100 kHz = 100 clamped samples in a row.
    ASSERT_TRUE(lim.configure({0.0f, 100.0f, 2e5f, 1.0e-3f}).ok());
    for (int i = 0; i < 99; ++i) lim.apply(130.0f);
    EXPECT_FALSE(lim.tripped());
    lim.apply(50.0f);  // one unclamped sample restarts the count
    for (int i = 0; i < 99; ++i) lim.apply(-10.0f);
    EXPECT_FALSE(lim.tripped());
    lim.apply(-10.0f);
    EXPECT_TRUE(lim.tripped());
    EXPECT_EQ(lim.trip_reason(), TripReason::kSustainedSaturation);
    EXPECT_TRUE(lim.clear_trip());
    EXPECT_FALSE(lim.tripped());
}

TEST(Limits, ExternalTripLatches) {
    OutputLimiter<Q31> lim(kHard, kRate, SignalScale{150.0f});
    ASSERT_TRUE(lim.configure(good_config()).ok());
    lim.trip(TripReason::kExternal);
    EXPECT_EQ(lim.trip_reason(), TripReason::kExternal);
    lim.trip(TripReason::kSustainedSaturation);
    EXPECT_EQ(lim.trip_reason(), TripReason::kExternal);
    EXPECT_TRUE(lim.clear_trip());
    EXPECT_FALSE(lim.tripped());
}

TEST(Limits, Q31ClampAndSlewAreExactInLsb) {
    const float fs = 150.0f;
    OutputLimiter<Q31> lim(kHard, kRate, SignalScale{fs});
    ASSERT_TRUE(lim.configure({0.0f, 100.0f, 1.0e4f, 0.0f}).ok());
    // Independent: the largest raw value whose voltage is <= 100 V, and the
    // largest step <= 0.1 V (long double, 64-bit mantissa: exact here).
    const int64_t hi = static_cast<int64_t>(std::floor(100.0L / fs * 2147483648.0L));
    const int64_t step = static_cast<int64_t>(std::floor(1.0e4L / kRate / fs * 2147483648.0L));
    EXPECT_EQ(lim.step_per_sample(), step);
    int32_t prev = lim.output().raw();
    EXPECT_EQ(prev, 0);
    for (int i = 0; i < 1200; ++i) {
        const int32_t y = lim.apply(Q31::max_value()).raw();
        EXPECT_LE(y - prev, step);
        prev = y;
    }
    EXPECT_EQ(prev, hi);
    EXPECT_LE(static_cast<long double>(prev) * fs / 2147483648.0L, 100.0L);
}

TEST(Limits, Q31HardLimitAtTheRoundingEdgeOfDouble) {
    // u / fs * 2^31 = n - 1/mf exactly, with mf = 8388609 (fs = mf * 2^-16,
    // u = 8355841 * 2^-16): 1/mf is below half a double ulp at 2^31, so the
    // double quotient rounds to the integer n and a plain floor would put the
    // top output 1/mf LSB *above* the hard limit (found with exact rationals
    // in Python). Same at the bottom with -u and ceil.
    const float fs = 128.00001525878906f;
    const float u = 127.50001525878906f;
    ASSERT_EQ(static_cast<double>(fs), 8388609.0 * 0x1p-16);
    ASSERT_EQ(static_cast<double>(u), 8355841.0 * 0x1p-16);
    OutputLimiter<Q31> lim(HardLimits{-u, u, 1.0e7f}, kRate, SignalScale{fs});
    ASSERT_TRUE(lim.hard_status().ok());
    // Exact in long double: raw * fs has at most 31 + 24 bits.
    EXPECT_LE(static_cast<long double>(lim.hard_max().raw()) * fs, static_cast<long double>(u) * 2147483648.0L);
    EXPECT_GE(static_cast<long double>(lim.hard_min().raw()) * fs, -static_cast<long double>(u) * 2147483648.0L);
    EXPECT_EQ(lim.hard_max().raw(), 2139095040);  // n - 1
    ASSERT_TRUE(lim.configure({-u, u, 1.0e7f, 0.0f}).ok());
    int32_t y = 0;
    for (int i = 0; i < 100; ++i) y = lim.apply(Q31::max_value()).raw();
    EXPECT_EQ(y, 2139095040);
    for (int i = 0; i < 200; ++i) y = lim.apply(Q31::min_value()).raw();
    EXPECT_EQ(y, -2139095040);
}

// ---- randomized properties -------------------------------------------------

// >= 1e6 hostile inputs with hostile reconfigurations, clear_trip and trip
// calls: the float output stays within the hard limits (exactly) and never
// moves by more than slew_max / rate in one sample (exactly, checked in long
// double where the difference of two floats in [-20, 120] is exact).
TEST(Limits, PropertyFloatNeverLeavesTheHardEnvelope) {
    OutputLimiter<float> lim(kHard, kRate);
    Hostile h(0x5eed0001);
    const long double hard_step = static_cast<long double>(kHard.slew_max_V_per_s) / kRate;
    float prev = lim.output();
    int accepted = 0, rejected = 0, trips = 0;
    float held = 0.0f;
    for (int i = 0; i < 1'200'000; ++i) {
        const int action = h.pick(4000);
        if (action < 2) {
            const LimitsConfig before = lim.config();
            const LimitsConfig c = h.config();
            if (lim.configure(c).ok()) {
                ++accepted;
                ASSERT_TRUE(obeys_rules(c, kHard)) << "accepted a config that breaks the rules";
                ASSERT_TRUE(same_config(lim.config(), c));
            } else {
                ++rejected;
                ASSERT_TRUE(same_config(lim.config(), before)) << "rejected config changed the state";
            }
        } else if (action < 4) {
            lim.clear_trip();
        } else if (action < 5) {
            lim.trip();
        }
        // Inputs: hostile values mixed with runs of one value so the output
        // also settles and slews over long distances.
        float u;
        if (h.pick(8) == 0) held = h.any_float();
        if (h.pick(3) == 0) u = h.any_float(); else u = held;
        const float y = lim.apply(u);
        if (lim.tripped()) ++trips;
        ASSERT_TRUE(std::isfinite(y)) << i;
        ASSERT_GE(y, kHard.u_min_V) << i;
        ASSERT_LE(y, kHard.u_max_V) << i;
        const long double d = static_cast<long double>(y) - static_cast<long double>(prev);
        ASSERT_LE(std::fabs(d), hard_step) << "sample " << i << " from " << prev << " to " << y;
        prev = y;
    }
    // The generator must exercise both paths and the trip logic.
    EXPECT_GT(accepted, 50);
    EXPECT_GT(rejected, 50);
    EXPECT_GT(trips, 1000);
    EXPECT_GT(lim.clamped_samples(), 1000u);
    EXPECT_GT(lim.slew_limited_samples(), 1000u);
}

// Same for Q31 over several (hard limits, output scale) pairs, including a
// hard range wider than the full scale and one that excludes 0 V.
TEST(Limits, PropertyQ31NeverLeavesTheHardEnvelope) {
    struct Board { HardLimits hard; float full_scale; };
    const Board boards[] = {
        {kHard, 150.0f},
        {{-30.0f, 130.0f, 1.0e6f}, 100.0f},  // hard wider than the scale on top
        {{-5.0f, 5.0f, 3.0e3f}, 1000.0f},    // small range, coarse steps in LSB
        {{10.0f, 60.0f, 5.0e5f}, 64.0f},     // 0 V is outside: safe = 10 V
    };
    Hostile h(0x5eed0002);
    for (const Board& b : boards) {
        OutputLimiter<Q31> lim(b.hard, kRate, SignalScale{b.full_scale});
        ASSERT_TRUE(lim.hard_status().ok());
        const long double fs = b.full_scale;
        const long double two31 = 2147483648.0L;
        const long double hard_step_lsb = static_cast<long double>(b.hard.slew_max_V_per_s) / kRate / fs * two31;
        int32_t prev = lim.output().raw();
        int accepted = 0, rejected = 0;
        int32_t held = 0;
        for (int i = 0; i < 300'000; ++i) {
            const int action = h.pick(4000);
            if (action < 2) {
                const LimitsConfig before = lim.config();
                LimitsConfig c = h.config();
                // Rescale plausible values to this board so some get accepted.
                if (std::isfinite(c.u_min_V) && std::isfinite(c.u_max_V) && h.pick(2)) {
                    const float span = b.hard.u_max_V - b.hard.u_min_V;
                    c.u_min_V = b.hard.u_min_V + span * static_cast<float>(h.uni(-0.1, 0.6));
                    c.u_max_V = b.hard.u_min_V + span * static_cast<float>(h.uni(0.4, 1.1));
                    c.slew_V_per_s = b.hard.slew_max_V_per_s * static_cast<float>(h.uni(-0.1, 1.2));
                }
                if (lim.configure(c).ok()) {
                    ++accepted;
                    ASSERT_TRUE(obeys_rules(c, b.hard));
                } else {
                    ++rejected;
                    ASSERT_TRUE(same_config(lim.config(), before));
                }
            } else if (action < 4) {
                lim.clear_trip();
            } else if (action < 5) {
                lim.trip();
            }
            if (h.pick(8) == 0) {
                const int k = h.pick(4);
                held = k == 0 ? Q31::kMaxRaw : (k == 1 ? Q31::kMinRaw : static_cast<int32_t>(h.rng()()));
            }
            const Q31 u = h.pick(3) == 0 ? Q31::from_raw(static_cast<int32_t>(h.rng()())) : Q31::from_raw(held);
            const int32_t y = lim.apply(u).raw();
            const long double volts = static_cast<long double>(y) * fs / two31;  // exact
            ASSERT_GE(volts, b.hard.u_min_V) << i;
            ASSERT_LE(volts, b.hard.u_max_V) << i;
            ASSERT_LE(std::fabs(static_cast<long double>(y) - prev), hard_step_lsb) << i;
            prev = y;
        }
        EXPECT_GT(accepted, 10) << b.full_scale;
        EXPECT_GT(rejected, 10) << b.full_scale;
        EXPECT_GT(lim.clamped_samples(), 1000u);
    }
}

// configure() is prepare() + apply_setting(): a limiter set up in two halves
// (as the pipeline does: prepare in the main loop, apply in the tick) gives
// the same outputs as one configured directly; a rejected prepare() leaves
// the setting it was given untouched. Seeded mt19937_64 inputs.
TEST(Limits, PrepareThenApplyEqualsConfigure) {
    const LimitsConfig first{-5.0f, 100.0f, 1.0e5f, 0.0f};
    const LimitsConfig second{0.0f, 50.0f, 5.0e4f, 1e-3f};
    OutputLimiter<float> a(kHard, kRate), b(kHard, kRate);
    OutputLimiter<Q31> qa(kHard, kRate, SignalScale{150.0f}), qb(kHard, kRate, SignalScale{150.0f});
    ASSERT_TRUE(a.configure(first).ok());
    ASSERT_TRUE(qa.configure(first).ok());
    OutputLimiter<float>::Setting s{};
    OutputLimiter<Q31>::Setting qs{};
    ASSERT_TRUE(b.prepare(first, s).ok());
    ASSERT_TRUE(qb.prepare(first, qs).ok());
    b.apply_setting(s);
    qb.apply_setting(qs);
    // Invalid: the setting passed in stays as it was.
    const OutputLimiter<float>::Setting before = s;
    EXPECT_FALSE(b.prepare(LimitsConfig{0.0f, 500.0f, 1.0e5f, 0.0f}, s).ok());
    EXPECT_TRUE(same_config(s.cfg, before.cfg));
    EXPECT_EQ(s.step, before.step);
    std::mt19937_64 rng(7);
    std::uniform_real_distribution<float> u(-40.0f, 140.0f);
    for (int k = 0; k < 4000; ++k) {
        if (k == 2000) {
            ASSERT_TRUE(a.configure(second).ok());
            ASSERT_TRUE(qa.configure(second).ok());
            ASSERT_TRUE(b.prepare(second, s).ok());
            ASSERT_TRUE(qb.prepare(second, qs).ok());
            b.apply_setting(s);
            qb.apply_setting(qs);
        }
        const float x = u(rng);
        ASSERT_EQ(std::bit_cast<uint32_t>(a.apply(x)), std::bit_cast<uint32_t>(b.apply(x))) << k;
        const Q31 xq = SignalScale{150.0f}.to_sample<Q31>(x);
        ASSERT_EQ(qa.apply(xq).raw(), qb.apply(xq).raw()) << k;
    }
    EXPECT_EQ(a.trip_reason(), b.trip_reason());
    EXPECT_EQ(a.clamped_samples(), b.clamped_samples());
    EXPECT_EQ(qa.trip_reason(), qb.trip_reason());
    EXPECT_TRUE(same_config(b.config(), second));
}
