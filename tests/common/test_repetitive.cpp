// Plug-in repetitive controller (docs/models.md, 'Repetitive control').
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <utility>
#include <vector>

#include "piezoloop/pid.hpp"
#include "piezoloop/repetitive.hpp"
#include "piezoloop/tustin.hpp"

using namespace piezoloop;

namespace {

// RC(z) written as one difference equation in z^-1 (independent of the
// delay-line realisation): with Q = q z^-1 / (1 - a z^-1),
//   RC = k q z^-(N-m1-m2+1) / (1 - a z^-1 - q z^-(N-m1+1)).
std::vector<double> rc_difference_equation(const std::vector<double>& e, int n, int m1, int m2,
                                           double k, double q, double a) {
    std::vector<double> y(e.size(), 0.0);
    const int nb = n - m1 - m2 + 1, na = n - m1 + 1;
    for (size_t i = 0; i < e.size(); ++i) {
        const long t = static_cast<long>(i);
        double v = 0.0;
        if (t - nb >= 0) v += k * q * e[static_cast<size_t>(t - nb)];
        if (t - 1 >= 0) v += a * y[static_cast<size_t>(t - 1)];
        if (t - na >= 0) v += q * y[static_cast<size_t>(t - na)];
        y[i] = v;
    }
    return y;
}

// Linear stand-in plant at 100 kHz: 3 kHz lag and a 18 kHz resonance
// (zeta 0.3), unit DC gain, as two sections in double.
struct LinearPlant {
    SosSection s[2];
    double x[2][2] = {};
    LinearPlant() {
        EXPECT_TRUE(tustin(first_order_lag(3e3), 1e5, s[0]).ok());
        EXPECT_TRUE(tustin(resonance(18e3, 0.3), 1e5, s[1]).ok());
    }
    double step(double u) {
        for (int i = 0; i < 2; ++i) {  // DF2T in double
            const double y = s[i].b0 * u + x[i][0];
            x[i][0] = s[i].b1 * u - s[i].a1 * y + x[i][1];
            x[i][1] = s[i].b2 * u - s[i].a2 * y;
            u = y;
        }
        return u;
    }
};

// Closed loop: PI feedback with optional RC, one tick of compute delay, a
// 1 kHz sine reference (N = 100 at 100 kHz). Returns the RMS error over the
// last period. The PI gains are lower than Shan2012's (whose plant is not
// published) so that this stand-in loop is stable with margin. The RC uses
// m1 = 3, the low-frequency group delay of the published Q (1 + 0.6442/0.3558
// = 2.8 samples), so Q z^m1 is close to 1 at the harmonic and the internal
// model's gain there is ~50; m2 = 2 leads the closed loop's lag.
template <class T>
double closed_loop_rms(bool with_rc, int periods) {
    const SignalScale pos{20.0f}, volt{20.0f};
    Pid<T> pid;
    PidConfig pc{0.3f, 20000.0f, 0.0f, 10000.0f, -15.0f, 15.0f};
    EXPECT_TRUE(pid.configure(pc, 1e5f, pos, volt).ok());
    RepetitiveController<T, 128> rc;
    RepetitiveConfig c;
    c.m1 = 3;
    c.m2 = 2;
    EXPECT_TRUE(rc.configure(c).ok());
    LinearPlant plant;
    double y = 0.0, sq = 0.0;
    const int n = 100;
    for (int k = 0; k < periods * n; ++k) {
        const double r = 5.0 * std::sin(2.0 * M_PI * (k % n) / n);
        if (k >= (periods - 1) * n) sq += (r - y) * (r - y);  // e[k] = r[k] - y[k]
        const T e = pos.to_sample<T>(static_cast<float>(r - y));
        const T e_aug = with_rc ? e + rc.apply(e) : e;
        const double u = volt.to_physical(pid.apply(e_aug));
        y = plant.step(u);
    }
    return std::sqrt(sq / n);
}

}  // namespace

TEST(Repetitive, ImpulseResponseMatchesDifferenceEquation) {
    for (int m2 : {0, 3}) {
        RepetitiveConfig c;
        c.m2 = m2;
        RepetitiveController<float, 128> rc;
        ASSERT_TRUE(rc.configure(c).ok());
        std::vector<double> e(1000, 0.0);
        e[0] = 1.0;
        e[137] = -0.5;
        const auto ref = rc_difference_equation(e, 100, 6, m2, 0.8, 0.3558, 0.6442);
        for (size_t i = 0; i < e.size(); ++i) {
            // float recursion over ~10 periods: relative 1e-6 of the peak (0.8).
            EXPECT_NEAR(rc.apply(static_cast<float>(e[i])), ref[i], 1e-6) << "m2=" << m2 << " k=" << i;
        }
    }
}

TEST(Repetitive, Q31MatchesFloatWithinStatedLsb) {
    RepetitiveController<float, 128> rf;
    RepetitiveController<Q31, 128> rq;
    ASSERT_TRUE(rf.configure(RepetitiveConfig{}).ok());
    ASSERT_TRUE(rq.configure(RepetitiveConfig{}).ok());
    double worst = 0.0;
    for (int k = 0; k < 5000; ++k) {
        const float e = 0.1f * static_cast<float>(std::sin(0.0628 * k) + 0.3 * std::sin(0.9 * k));
        const double a = rf.apply(e);
        const double b = rq.apply(Q31::from_float(e)).to_double();
        worst = std::max(worst, std::fabs(a - b));
    }
    // Both sides round (Q31 at 2^-31, float at 2^-24 of ~0.4) and the
    // periodic loop accumulates rounding with its gain at the harmonics (~5
    // for the published m1 = 6): 2^-18 = 3.8e-6 bounds it; measured 1.1e-6.
    EXPECT_LT(worst, std::ldexp(1.0, -18));
}

TEST(Repetitive, SteadyStateErrorFallsAtLeast20dB) {
    for (bool q31 : {false, true}) {
        const double without = q31 ? closed_loop_rms<Q31>(false, 400) : closed_loop_rms<float>(false, 400);
        const double with = q31 ? closed_loop_rms<Q31>(true, 400) : closed_loop_rms<float>(true, 400);
        std::printf("%s: e_rms without RC %.4g um, with RC %.4g um (%.1f dB)\n", q31 ? "q31" : "float",
                    without, with, 20.0 * std::log10(without / with));
        EXPECT_LT(with, 0.1 * without) << (q31 ? "q31" : "float");
    }
}

TEST(Repetitive, RejectsBadConfigAndKeepsOld) {
    RepetitiveController<float, 128> rc;
    ASSERT_TRUE(rc.configure(RepetitiveConfig{}).ok());
    RepetitiveConfig bad;
    bad.period_samples = 129;
    EXPECT_STREQ(rc.configure(bad).field, "period_samples");
    bad = {};
    bad.m1 = 60;
    bad.m2 = 40;
    EXPECT_STREQ(rc.configure(bad).field, "m2");
    bad = {};
    bad.k_rc = 2.0f;
    EXPECT_STREQ(rc.configure(bad).field, "k_rc");
    bad = {};
    bad.q.a2 = 1.5;  // unstable Q
    EXPECT_FALSE(rc.configure(bad).ok());
    EXPECT_EQ(rc.config().period_samples, 100);
    EXPECT_FLOAT_EQ(rc.config().k_rc, 0.8f);
}

// N - m1 - m2 >= 1 with m1, m2 near 2^31: in 32 bits the difference wraps
// to a positive value and a negative delay would reach the delay line.
TEST(Repetitive, LeadsNearTwoToThe31AreRefused) {
    constexpr int32_t kMax = INT32_MAX;
    using Rc = RepetitiveController<float, 128>;
    for (const int32_t n : {2, 100, 128}) {
        for (const auto& [m1, m2] : {std::pair{kMax, kMax}, std::pair{kMax, 1}, std::pair{1, kMax},
                                     std::pair{kMax - n, kMax}, std::pair{kMax / 2 + 1, kMax / 2 + 1},
                                     std::pair{n, 0}, std::pair{0, n}}) {
            RepetitiveConfig c;
            c.period_samples = n;
            c.m1 = m1;
            c.m2 = m2;
            EXPECT_STREQ(Rc::validate(c).field, "m2") << n << " " << m1 << " " << m2;
        }
        RepetitiveConfig edge;  // the longest leads that keep one sample of delay
        edge.period_samples = n;
        edge.m1 = n - 1;
        edge.m2 = 0;
        EXPECT_TRUE(Rc::validate(edge).ok()) << n;
    }
}

// A Q that is not first order runs through the biquad realisation: the
// published Q times a cancelling pole/zero pair at z = 0.5 has the same
// response, so the same difference equation is the reference.
TEST(Repetitive, SecondOrderQMatchesTheFirstOrderResponse) {
    RepetitiveConfig c;
    // 0.3558 z^-1 (1 - 0.5 z^-1) / ((1 - 0.6442 z^-1)(1 - 0.5 z^-1))
    c.q = SosSection{0.0, 0.3558, -0.1779, -1.1442, 0.3221};
    for (int m2 : {0, 3}) {
        c.m2 = m2;
        RepetitiveController<float, 128> rf;
        RepetitiveController<Q31, 128> rq;
        ASSERT_TRUE(rf.configure(c).ok());
        ASSERT_TRUE(rq.configure(c).ok());
        std::vector<double> e(1000, 0.0);
        e[0] = 0.5;
        e[137] = -0.25;
        const auto ref = rc_difference_equation(e, 100, 6, m2, 0.8, 0.3558, 0.6442);
        for (size_t i = 0; i < e.size(); ++i) {
            // As the first-order test, plus the float rounding of the
            // cancelling pair (coefficients to 2^-24, the extra pole's state):
            // 1e-5 of the peak of 0.4.
            EXPECT_NEAR(rf.apply(static_cast<float>(e[i])), ref[i], 1e-5) << "m2=" << m2 << " k=" << i;
            // Q31 (DF1 with error feedback, 2^-31 steps): the same bound.
            EXPECT_NEAR(rq.apply(Q31::from_double(e[i])).to_double(), ref[i], 1e-5) << "m2=" << m2 << " k=" << i;
        }
    }
}

// The first-order Q31 section against the float section on a random input:
// both realise Q exactly up to their rounding (Q31 coefficients and output
// at 2^-31 with error feedback, float at 2^-24 of ~1).
TEST(Repetitive, FirstOrderQ31SectionMatchesFloat) {
    const SosSection q{0.1, 0.3558, 0.0, -0.6442, 0.0};
    ASSERT_TRUE(FirstOrderSection<Q31>::accepts(q));
    FirstOrderSection<float> f;
    FirstOrderSection<Q31> g;
    f.configure(q);
    g.configure(q);
    f.reset();
    g.reset();
    uint32_t s = 12345u;
    double worst = 0.0;
    for (int k = 0; k < 20000; ++k) {
        s = s * 1664525u + 1013904223u;  // seeded LCG
        const float x = (static_cast<float>(s >> 8) / 16777216.0f - 0.5f) * 0.9f;
        worst = std::max(worst, std::fabs(static_cast<double>(f.apply(x)) - g.apply(Q31::from_float(x)).to_double()));
    }
    // DC gain (0.1 + 0.3558) / (1 - 0.6442) = 1.28 on rounding of ~6e-8
    // (float) per step: 1e-6 bounds it.
    EXPECT_LT(worst, 1e-6);
    // Coefficients of 1 or more, or a second-order Q, take the biquad.
    EXPECT_FALSE(FirstOrderSection<Q31>::accepts(SosSection{1.0, 0.0, 0.0, -0.5, 0.0}));
    EXPECT_FALSE(FirstOrderSection<Q31>::accepts(SosSection{0.1, 0.2, 0.1, -0.5, 0.0}));
    EXPECT_TRUE(FirstOrderSection<float>::accepts(SosSection{1.0, 0.0, 0.0, -0.5, 0.0}));
}

// A reconfiguration copies and clears only the period's samples of the
// delay line (delay_line.hpp). A controller continued by assignment, into
// one whose line holds other data everywhere, must compute what the
// original computes, sample for sample; and one configured again must
// compute what a fresh one does, whatever its line held before.
TEST(Repetitive, ContinuingAndResettingTouchOnlyThePeriod) {
    using Rc = RepetitiveController<float, 256>;
    RepetitiveConfig c;
    c.period_samples = 100;
    c.m2 = 3;
    auto input = [](int k) { return static_cast<float>(std::sin(0.37 * k) + 0.25 * std::cos(0.011 * k * k)); };
    Rc original, dirty, fresh;
    RepetitiveConfig long_period = c;
    long_period.period_samples = 256;
    ASSERT_TRUE(dirty.configure(long_period).ok());
    for (int k = 0; k < 700; ++k) dirty.apply(100.0f + input(k));  // every slot of its line written
    ASSERT_TRUE(original.configure(c).ok());
    for (int k = 0; k < 345; ++k) original.apply(input(k));
    Rc continued = dirty;
    continued = original;
    for (int k = 345; k < 1000; ++k) ASSERT_EQ(continued.apply(input(k)), original.apply(input(k))) << k;

    ASSERT_TRUE(dirty.configure(c).ok());
    ASSERT_TRUE(fresh.configure(c).ok());
    for (int k = 0; k < 1000; ++k) ASSERT_EQ(dirty.apply(input(k)), fresh.apply(input(k))) << k;
}
