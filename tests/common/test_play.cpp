// Play and stop operators against their definitions (docs/models.md, 'Play and stop operators').
#include <gtest/gtest.h>

#include <random>
#include <vector>

#include "piezoloop/play.hpp"

using piezoloop::PlayOperator;
using piezoloop::Q31;

TEST(Play, StaysWithinThresholdAndStopComplementsPlay) {
    std::mt19937 rng(7);
    std::uniform_real_distribution<float> du(-10.0f, 10.0f);
    for (float r : {0.0f, 0.5f, 3.0f}) {
        PlayOperator<float> op(r);
        for (int k = 0; k < 100000; ++k) {
            const float u = du(rng);
            const float w = op.apply(u);
            // |u - w| <= r exactly: w is u - r, u + r or a value between.
            // The float subtraction u - w can round up by half an ulp of u.
            EXPECT_LE(std::fabs(u - w), r + 1e-6f);
            EXPECT_EQ(op.stop_of(u) + w, u);  // stop + play = input
        }
    }
}

TEST(Play, ZeroThresholdIsIdentity) {
    PlayOperator<float> op(0.0f);
    for (float u : {1.0f, -3.0f, 2.5f, 2.5f, -0.125f}) EXPECT_EQ(op.apply(u), u);
}

TEST(Play, KnownBacklashSequence) {
    // Reference worked by hand from w = max(u - r, min(u + r, w)), r = 1.
    PlayOperator<float> op(1.0f);
    const float u[] = {0.5f, 2.0f, 3.0f, 2.5f, 1.0f, 0.0f, 1.5f};
    const float w[] = {0.0f, 1.0f, 2.0f, 2.0f, 2.0f, 1.0f, 1.0f};
    for (int k = 0; k < 7; ++k) EXPECT_EQ(op.apply(u[k]), w[k]) << "k=" << k;
}

TEST(Play, RateIndependentForResampledMonotoneSegments) {
    // The same turning points, joined by 1, 7 or 1000 monotone steps, give
    // identical operator outputs at every turning point.
    const std::vector<float> turns = {0.0f, 4.0f, 1.5f, 3.0f, -2.0f, 0.25f, -5.0f, 5.0f};
    std::vector<std::vector<float>> at_turns;
    for (int steps : {1, 7, 1000}) {
        PlayOperator<float> op(0.75f);
        std::vector<float> out;
        float prev = turns[0];
        op.apply(prev);
        for (size_t i = 1; i < turns.size(); ++i) {
            for (int s = 1; s <= steps; ++s)
                op.apply(prev + (turns[i] - prev) * (static_cast<float>(s) / static_cast<float>(steps)));
            out.push_back(op.state());
            prev = turns[i];
        }
        at_turns.push_back(out);
    }
    EXPECT_EQ(at_turns[0], at_turns[1]);
    EXPECT_EQ(at_turns[0], at_turns[2]);
}

TEST(Play, Q31SaturationKeepsSemantics) {
    // Near full scale u + r saturates; the result must equal the exact play
    // computed in 64-bit integers, clamped to the Q31 range.
    std::mt19937 rng(3);
    std::uniform_int_distribution<int32_t> d(Q31::kMinRaw, Q31::kMaxRaw);
    const int32_t r = 1 << 29;
    PlayOperator<Q31> op(Q31::from_raw(r));
    int64_t w_exact = 0;
    for (int k = 0; k < 100000; ++k) {
        const int32_t u = d(rng);
        w_exact = std::max<int64_t>(int64_t{u} - r, std::min<int64_t>(int64_t{u} + r, w_exact));
        w_exact = std::clamp<int64_t>(w_exact, Q31::kMinRaw, Q31::kMaxRaw);
        EXPECT_EQ(op.apply(Q31::from_raw(u)).raw(), w_exact);
    }
}
