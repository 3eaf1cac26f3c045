// The approach against its closed form, the minimum-jerk profile
// r(t) = from + D (10 x^3 - 15 x^4 + 6 x^5), x = t / T, D = to - from,
// evaluated here in long double; the tick count against
// N = ceil(15/8 |D| / (v_max Ts)) computed here in double.
#include <gtest/gtest.h>

#include <cmath>
#include <cstdint>
#include <vector>

#include "piezoloop/approach.hpp"

using piezoloop::Approach;
using piezoloop::kApproachFullScalesPerSecond;
using piezoloop::Q31;
using piezoloop::SignalScale;

namespace {

constexpr float kRate_Hz = 100000.0f;
constexpr float kFullScale_um = 50.0f;
// v_max = 10 full scales per second: 500 um/s, 5e-3 um per tick.
constexpr double kVmax_um_per_tick = kApproachFullScalesPerSecond * kFullScale_um / kRate_Hz;

long double min_jerk(long double x) { return x * x * x * (10.0L - 15.0L * x + 6.0L * x * x); }

uint32_t expected_ticks(double d_um) {
    return static_cast<uint32_t>(std::ceil(15.0 / 8.0 * std::fabs(d_um) / kVmax_um_per_tick));
}

// A sample in µm, exactly (Q31 in double: a float would round it).
double um(float v, SignalScale) { return v; }
double um(Q31 v, SignalScale pos) { return v.raw() * 0x1p-31 * pos.full_scale; }

// The whole move as the pipeline produces it: sample 0 = from, the
// approach's samples, sample N = to.
template <class T>
std::vector<double> move_um(Approach<T>& a, T from, T to, SignalScale pos) {
    std::vector<double> r{um(from, pos)};
    EXPECT_TRUE(a.begin(from, to));
    while (a.moving()) r.push_back(um(a.step(), pos));
    r.push_back(um(to, pos));
    return r;
}

// tol_um: the closed form's error bound for this move (see the callers).
template <class T>
void check_move(float from_um, float to_um, double tol_um) {
    const SignalScale pos{kFullScale_um};
    Approach<T> a(pos, kRate_Hz);
    const T from = pos.to_sample<T>(from_um), to = pos.to_sample<T>(to_um);
    const double f = um(from, pos), t = um(to, pos), d = t - f;
    const uint32_t n = a.ticks_for(from, to);
    // Q31: the distance in raw LSBs; N may differ by one from the double
    // formula only where |D| / unit lands within rounding of an integer.
    EXPECT_NEAR(static_cast<double>(n), static_cast<double>(expected_ticks(d)), 1.0);
    const std::vector<double> r = move_um(a, from, to, pos);
    ASSERT_EQ(r.size(), n + 1u);
    double max_step = 0.0, max_err = 0.0, max_accel = 0.0;
    for (uint32_t k = 0; k <= n; ++k) {
        const long double x = static_cast<long double>(k) / n;
        max_err = std::max(max_err, static_cast<double>(std::fabs(r[k] - (f + d * min_jerk(x)))));
        if (k > 0) max_step = std::max(max_step, std::fabs(r[k] - r[k - 1]));
        if (k > 1) max_accel = std::max(max_accel, std::fabs(r[k] - 2 * r[k - 1] + r[k - 2]));
    }
    EXPECT_LE(max_err, tol_um) << from_um << " -> " << to_um;
    // Velocity bound: no step beyond v_max * Ts (the closed form's peak is
    // 15/8 |D| / T <= v_max; the sampled steps are its means over a tick).
    EXPECT_LE(max_step, kVmax_um_per_tick + 2 * tol_um);
    // The peak is reached: N is the shortest move within the bound.
    EXPECT_GT(max_step, 0.9 * 15.0 / 8.0 * std::fabs(d) / n);
    // Continuous first derivative: the moves at both ends start and end at
    // rest, the first and last steps D (10 / N^3 + O(N^-4)).
    const double end_step = 11.0 * std::fabs(d) / (static_cast<double>(n) * n * n) + 2 * tol_um;
    EXPECT_LE(std::fabs(r[1] - r[0]), end_step);
    EXPECT_LE(std::fabs(r[n] - r[n - 1]), end_step);
    // Bounded acceleration: second differences within the closed form's
    // peak, 10 / sqrt(3) |D| / N^2 per tick^2.
    EXPECT_LE(max_accel, 10.0 / std::sqrt(3.0) * std::fabs(d) / (static_cast<double>(n) * n) + 4 * tol_um);
}

}  // namespace

TEST(Approach, FloatFollowsTheMinimumJerkProfileWithinTheSpeedBound) {
    // Float: s is converted to float (2^-24 relative), D s and the sum
    // round to half an ulp each: within 2^-22 (|D| + |the larger end|).
    auto tol = [](double a, double b) { return 0x1p-22 * (std::fabs(b - a) + std::max(std::fabs(a), std::fabs(b))); };
    check_move<float>(0.0f, -15.0f, tol(0, -15));
    check_move<float>(3.25f, 30.0f, tol(3.25, 30));
    check_move<float>(-40.0f, 45.0f, tol(-40, 45));
    check_move<float>(0.0f, 0.02f, tol(0, 0.02));  // a few ticks
}

TEST(Approach, Q31FollowsTheMinimumJerkProfileWithinTheSpeedBound) {
    // Q31: the shape's error (below 2^-26, approach.hpp) times |D|, plus
    // the output's rounding to one LSB (50 um / 2^31 = 2.3e-8 um).
    auto tol = [](double a, double b) { return 0x1p-26 * std::fabs(b - a) + 0x1p-31 * kFullScale_um; };
    check_move<Q31>(0.0f, -15.0f, tol(0, -15));
    check_move<Q31>(3.25f, 30.0f, tol(3.25, 30));
    check_move<Q31>(-49.0f, 49.5f, tol(-49, 49.5));
    check_move<Q31>(0.0f, 0.02f, tol(0, 0.02));
}

TEST(Approach, DistancesWithinOneTickTakeNoTick) {
    const SignalScale pos{kFullScale_um};
    Approach<float> a(pos, kRate_Hz);
    EXPECT_EQ(a.ticks_for(5.0f, 5.0f), 0u);
    EXPECT_FALSE(a.begin(5.0f, 5.0f));
    EXPECT_FALSE(a.moving());
    // unit = 8/15 v_max Ts: a move that short fits one tick.
    const float unit = a.unit();
    EXPECT_NEAR(unit, 8.0 / 15.0 * kVmax_um_per_tick, 1e-9);
    EXPECT_EQ(a.ticks_for(0.0f, unit), 1u);
    EXPECT_FALSE(a.begin(0.0f, unit));
    EXPECT_EQ(a.ticks_for(0.0f, 2.5f * unit), 3u);
    Approach<Q31> q(pos, kRate_Hz);
    EXPECT_EQ(q.ticks_for(Q31::from_raw(-7), Q31::from_raw(-7)), 0u);
    EXPECT_EQ(q.ticks_for(Q31::from_raw(0), Q31::from_raw(1000)), 1u);  // 1000 LSB < unit
    // Full span of Q31 (-FS .. +FS): 2 FS at 10 FS/s, T = 15/8 * 0.2 s.
    EXPECT_NEAR(q.ticks_for(Q31::from_raw(Q31::kMinRaw), Q31::from_raw(Q31::kMaxRaw)), 37500.0, 1.0);
    // A NaN start is no move (the pipeline never feeds one: setpoints are checked).
    EXPECT_EQ(a.ticks_for(NAN, 1.0f), 0u);
}

TEST(Approach, FloatAndQ31ShareTheShape) {
    // Same move in both types: the shapes are the same integers, so the two
    // approaches differ by the output's rounding only.
    const SignalScale pos{kFullScale_um};
    Approach<float> a(pos, kRate_Hz);
    Approach<Q31> q(pos, kRate_Hz);
    const float from = -12.5f, to = 25.0f;
    const std::vector<double> rf = move_um(a, from, to, pos);
    const std::vector<double> rq = move_um(q, pos.to_sample<Q31>(from), pos.to_sample<Q31>(to), pos);
    ASSERT_EQ(rf.size(), rq.size());
    for (std::size_t k = 0; k < rf.size(); ++k) ASSERT_NEAR(rf[k], rq[k], 5e-6) << k;
}
