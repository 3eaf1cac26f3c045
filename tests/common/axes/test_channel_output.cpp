// The channel stage of a multi-axis board: every channel within its hard
// range and slew whatever the matrix and the commands (overflowing floats,
// Q31 extremes), and the identity's skip rule.
#include <gtest/gtest.h>

#include <array>
#include <cstdint>
#include <random>

#include "axes_property.hpp"
#include "piezoloop/axes/channel_output.hpp"

using namespace piezoloop;
using namespace piezoloop::test;

namespace {

template <class T, int N>
void channel_stage_property(uint64_t seed) {
    std::mt19937_64 rng(seed);
    std::uniform_real_distribution<float> lo(-60.0f, -1.0f), hi(1.0f, 60.0f), slew(1.0e4f, 1.0e6f);
    ChannelBounds<T, N> b;
    b.rate_Hz = 100000.0;
    std::array<HardLimits, N> axis_hard{};
    for (int i = 0; i < N; ++i) {
        b.hard[i] = HardLimits{lo(rng), hi(rng), slew(rng)};
        b.scale[i] = SignalScale{150.0f};
        axis_hard[i] = HardLimits{-100.0f, 100.0f, 1.0e8f};  // wider: the stage always runs
        b.prev[i] = std::clamp(0.0, static_cast<double>(b.hard[i].u_min_V), static_cast<double>(b.hard[i].u_max_V));
    }
    ChannelOutput<T, N> out(b.hard, 100000.0f, b.scale, axis_hard);
    ASSERT_TRUE(out.hard_status().ok());
    for (int m = 0; m < 2000; ++m) {
        AxisTransform<T, N> t;
        const AxisMatrix<N> a = m % 7 == 0 ? AxisMatrix<N>::identity() : random_valid_matrix<N>(rng);
        ASSERT_TRUE(out.prepare(a, t).ok());
        out.set_matrix(t);
        if (m % 50 == 0) out.clear_trips();
        for (int k = 0; k < 8; ++k) {
            std::array<T, N> u{};
            for (int i = 0; i < N; ++i) u[i] = random_command<T>(rng);
            b.check(out.apply(u));
        }
    }
    EXPECT_EQ(b.violations, 0);
    for (int i = 0; i < N; ++i) {
        EXPECT_GT(out.clamped_samples(i), 0u);
        EXPECT_GT(out.slew_limited_samples(i), 0u);
    }
}

template <class T>
class ChannelOutputTyped : public ::testing::Test {};
using SampleTypes = ::testing::Types<float, Q31>;
TYPED_TEST_SUITE(ChannelOutputTyped, SampleTypes);

}  // namespace

TYPED_TEST(ChannelOutputTyped, StaysWithinHardLimitsAndSlew) {
    channel_stage_property<TypeParam, 2>(11);
    channel_stage_property<TypeParam, 3>(12);
}

TEST(ChannelOutput, AnIdentityStageIsSkippedOnlyOnceTheChannelsHaveCaughtUp) {
    const std::array<HardLimits, 2> hard{HardLimits{-10.0f, 10.0f, 1.0e5f}, HardLimits{-10.0f, 10.0f, 1.0e5f}};
    const std::array<SignalScale, 2> scale{SignalScale{12.0f}, SignalScale{12.0f}};
    ChannelOutput<float, 2> out(hard, 100000.0f, scale, hard);  // axes' limits = channels'
    EXPECT_FALSE(out.active());
    EXPECT_EQ(out.apply({3.0f, -2.0f}), (std::array<float, 2>{3.0f, -2.0f}));
    AxisMatrix<2> swap{};
    swap.m[0][1] = swap.m[1][0] = 1.0f;
    AxisTransform<float, 2> t;
    ASSERT_TRUE(out.prepare(swap, t).ok());
    out.set_matrix(t);
    EXPECT_TRUE(out.active());
    // From (3, -2) towards (-2, 3) at 1 V per tick (less one ulp of the
    // range: limits.hpp): no jump.
    const std::array<float, 2> first = out.apply({3.0f, -2.0f});
    EXPECT_NEAR(first[0], 2.0f, 1e-5f);
    EXPECT_NEAR(first[1], -1.0f, 1e-5f);
    EXPECT_LE(3.0f - first[0], 1.0f);
    ASSERT_TRUE(out.prepare(AxisMatrix<2>::identity(), t).ok());
    out.set_matrix(t);
    // Back towards (3, -2), still slew-limited, then skipped once reached.
    EXPECT_EQ(out.apply({3.0f, -2.0f}), (std::array<float, 2>{3.0f, -2.0f}));
    EXPECT_FALSE(out.active());
    EXPECT_EQ(out.slew_limited_samples(0), 1u);

    // A channel narrower than its axis is never skipped.
    const std::array<HardLimits, 2> wide{HardLimits{-20.0f, 10.0f, 1.0e5f}, hard[1]};
    ChannelOutput<float, 2> narrow(hard, 100000.0f, scale, wide);
    EXPECT_TRUE(narrow.active());
    EXPECT_NEAR(narrow.apply({-15.0f, 0.0f})[0], -1.0f, 1e-5f);
}
