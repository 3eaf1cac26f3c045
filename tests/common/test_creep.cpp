// The creep bank (common/piezoloop/creep.hpp) against the analytic step
// response of its lags, and its growth per decade against the percentage
// it is given.
#include <gtest/gtest.h>

#include <cmath>
#include <limits>

#include "piezoloop/creep.hpp"

using namespace piezoloop;

namespace {

// The analytic creep of a unit step at t (s): (p/100) sum_k w_k (1 - e^{-t/tau_k}).
double analytic(const CreepLags& l, double p, double t) {
    double s = 0.0;
    for (int k = 0; k < l.count; ++k)
        s += l.weight[static_cast<size_t>(k)] * (1.0 - std::exp(-t / l.tau_s[static_cast<size_t>(k)]));
    return p / 100.0 * s;
}

}  // namespace

TEST(Creep, LagsOnePerDecadeAndTheLastWeight) {
    CreepLags l;
    ASSERT_TRUE(creep_lags({2.0f, 0.01f, 100.0f}, l).ok());
    ASSERT_EQ(l.count, 5);
    for (int k = 0; k < 5; ++k) EXPECT_NEAR(l.tau_s[static_cast<size_t>(k)], 0.01 * std::pow(10.0, k), 1e-9 * std::pow(10.0, k));
    for (int k = 0; k < 4; ++k) EXPECT_EQ(l.weight[static_cast<size_t>(k)], 1.0);
    // The last weight, so the last decade grows by exactly 1 unit: computed
    // independently with numpy (1 - sum_{k<4} (e^{-10^{3-k}/10} ... )) as
    // 1.1772253808756648; det_exp is good to a few ulp.
    EXPECT_NEAR(l.weight[4], 1.1772253808756648, 1e-12);
    ASSERT_TRUE(creep_lags({1.0f, 0.1f, 1.0f}, l).ok());
    EXPECT_EQ(l.count, 2);
    // With one decade the last weight makes [0.1, 1] grow by 1: numpy 1.1773099311230186.
    EXPECT_NEAR(l.weight[1], 1.1773099311230186, 1e-12);
    ASSERT_TRUE(creep_lags({0.0f, 0.0f, 0.0f}, l).ok());
    EXPECT_EQ(l.count, 0);
}

TEST(Creep, StepResponseIsTheSumOfExponentialsAndGrowsPPercentPerDecade) {
    // 2 % per decade from 0.01 s to 100 s at 20 kHz, a 10 µm step held 100 s.
    const double rate = 20000.0, p = 2.0, h = 10.0;
    const CreepConfig c{static_cast<float>(p), 0.01f, 100.0f};
    CreepLags l;
    ASSERT_TRUE(creep_lags(c, l).ok());
    CreepBank bank;
    ASSERT_TRUE(bank.configure(c, static_cast<float>(rate)).ok());
    ASSERT_EQ(bank.count(), 5);
    const uint32_t n_total = 2000000;
    double worst_held = 0.0, worst_continuous = 0.0;
    // Creep at the decade boundaries (t = n / rate, n the samples applied).
    double at_decade[5] = {};
    for (uint32_t n = 1; n <= n_total; ++n) {
        const float out = bank.apply(static_cast<float>(h));
        ASSERT_EQ(out, static_cast<float>(h) + bank.creep_um());
        // The bank's own (held) response, exactly: lag k has had
        // m = floor(n / n_k) updates of gain g_k, so it holds h (1 - (1 - g_k)^m).
        if (n % 997 == 0 || n == n_total) {
            double held = 0.0;
            for (int k = 0; k < 5; ++k) {
                const double m = std::floor(static_cast<double>(n) / bank.period(k));
                held += l.weight[static_cast<size_t>(k)] * h * (1.0 - std::pow(1.0 - static_cast<double>(bank.gain(k)), m));
            }
            held *= p / 100.0;
            worst_held = std::max(worst_held, std::fabs(bank.creep_um() - held));
            worst_continuous = std::max(worst_continuous, std::fabs(bank.creep_um() - h * analytic(l, p, n / rate)));
        }
        for (int j = 0; j < 5; ++j)
            if (n == static_cast<uint32_t>(0.01 * std::pow(10.0, j) * rate + 0.5)) at_decade[j] = bank.creep_um();
    }
    // Held response: float rounding only. A lag stops moving once
    // g_k |h - s| < ulp(h) / 2 (g_k ~ 0.01, ulp(10) = 9.5e-7): 5e-5 µm of its
    // state, times (p/100) w_k ~ 0.024; five lags, 1e-5 µm with margin.
    EXPECT_LT(worst_held, 1e-5);
    // Against the continuous lags: lag k is at most tau_k / 100 late, and
    // 1 - e^{-t/tau} moves at most 1 / tau, so each is off by at most 1 %
    // of its weight: h (p/100) 0.01 sum_k w_k = 0.0104 µm.
    EXPECT_LT(worst_continuous, h * p / 100.0 * 0.01 * 5.18);
    // Growth over each whole decade: p % of the step (the bank's design:
    // within 0.6 % of p analytically; 1 % allows for the hold).
    for (int j = 0; j < 4; ++j) {
        const double per_decade = (at_decade[j + 1] - at_decade[j]) / h * 100.0;
        EXPECT_NEAR(per_decade, p, 0.01 * p) << "decade " << j;
    }
    // And Jung & Gweon's form y0 (1 + (p/100) log10(t/t0)) from t0 = 0.01 s:
    // p is taken per step height h (y0 = h + creep(t0) is 1.5 % above h), so
    // y(t) - y0 = h (p/100) log10(t / t0) within 1 % of p per decade.
    for (int j = 1; j < 5; ++j)
        EXPECT_NEAR((at_decade[j] - at_decade[0]) / h * 100.0, p * j, 0.01 * p * j) << "to decade " << j;
}

TEST(Creep, OffIsThePlainInputAndResetRestarts) {
    CreepBank off;
    ASSERT_TRUE(off.configure({}, 20000.0f).ok());
    EXPECT_FALSE(off.enabled());
    for (const float h : {0.0f, 1.234567f, -7.5f, 1e-30f}) EXPECT_EQ(off.apply(h), h);
    CreepBank on;
    ASSERT_TRUE(on.configure({3.0f, 0.001f, 1.0f}, 10000.0f).ok());
    float first[200];
    for (float& y : first) y = on.apply(5.0f);
    on.reset();
    for (const float y : first) ASSERT_EQ(on.apply(5.0f), y);
}

TEST(Creep, BadValuesAreRefusedByName) {
    const float nan = std::numeric_limits<float>::quiet_NaN();
    struct Bad {
        CreepConfig c;
        float rate;
        const char* field;
    };
    const Bad bad[] = {
        {{-1.0f, 0.01f, 100.0f}, 20000.0f, "percent_per_decade"},
        {{nan, 0.01f, 100.0f}, 20000.0f, "percent_per_decade"},
        {{25.0f, 0.01f, 100.0f}, 20000.0f, "percent_per_decade"},
        {{2.0f, 0.0f, 100.0f}, 20000.0f, "from_s"},
        {{2.0f, nan, 100.0f}, 20000.0f, "from_s"},
        {{2.0f, 0.01f, 50.0f}, 20000.0f, "to_s"},        // not a whole number of decades
        {{2.0f, 0.01f, 0.01f}, 20000.0f, "to_s"},        // no decade
        {{2.0f, 0.001f, 1e6f}, 20000.0f, "to_s"},        // 9 decades
        {{2.0f, 0.01f, nan}, 20000.0f, "to_s"},
        {{2.0f, 1e-4f, 1.0f}, 10000.0f, "from_s"},       // 1 sample per tau
        {{2.0f, 1000.0f, 1e6f}, 10000.0f, "to_s"},       // 1e10 samples
    };
    for (const Bad& b : bad) {
        CreepBank bank;
        const Status s = bank.configure(b.c, b.rate);
        ASSERT_FALSE(s.ok()) << b.field;
        EXPECT_STREQ(s.field, b.field);
    }
}
