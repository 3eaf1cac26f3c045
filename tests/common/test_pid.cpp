// PID (float and Q31) against analytic discrete sequences: Shan2012's
// Gc(z) = Kp + Ki Ts z/(z-1) for Kd = 0, the step response of the filtered
// derivative (Kd/tau) alpha^n, and anti-windup against a variant without it.
#include <gtest/gtest.h>

#include <cmath>
#include <cstdio>
#include <random>
#include <vector>

#include "piezoloop/pid.hpp"

using namespace piezoloop;

namespace {

constexpr double kLsb = 1.0 / 2147483648.0;
constexpr double kTwoPi = 6.283185307179586476925;

// The discrete law of pid.hpp written out in double from its equations:
// the reference for long random sequences.
struct DoublePid {
    double kp, ki_ts, kd_tau, beta, u_min, u_max;
    double i = 0.0, ef = 0.0;
    DoublePid(const PidConfig& c, double rate)
        : kp(c.kp), ki_ts(c.ki_per_s / rate), kd_tau(c.kd_s * kTwoPi * c.derivative_cutoff_Hz),
          beta(1.0 - std::exp(-kTwoPi * c.derivative_cutoff_Hz / rate)), u_min(c.u_min), u_max(c.u_max) {}
    double apply(double e) {
        const double p = kp * e, delta = e - ef, d = kd_tau * delta;
        ef += beta * delta;
        const double hi = std::max(i, u_max - p - d), lo = std::min(i, u_min - p - d);
        i = std::clamp(i + ki_ts * e, lo, hi);
        return std::clamp(p + d + i, u_min, u_max);
    }
};

}  // namespace

// ---------------------------------------------------------------------------
// Kd = 0 is exactly Gc(z) = Kp + Ki Ts z/(z-1): for a step E from rest,
// u[n] = Kp E + Ki Ts E (n + 1) (backward Euler includes the current sample).

TEST(Pid, KdZeroIsExactlyShan2012GcForAStepDyadic) {
    // Dyadic values make every float operation exact, so the sequence must be
    // reproduced bit for bit: Kp = 1.25, Ki Ts = 32768 / 65536 = 0.5, E = 0.25.
    Pid<float> f;
    ASSERT_TRUE(f.configure({1.25f, 32768.0f, 0.0f, 1000.0f, -1e4f, 1e4f}, 65536.0f, {}, {}).ok());
    for (int n = 0; n < 1000; ++n) ASSERT_EQ(f.apply(0.25f), 0.3125f + 0.125f * static_cast<float>(n + 1)) << n;

    // Q31 with a 1 V input and 512 V output scale: sample gains Kp / 512 and
    // Ki Ts / 512 are powers of two times 1.25 and 1, also exact.
    Pid<Q31> q;
    ASSERT_TRUE(q.configure({1.25f, 32768.0f, 0.0f, 1000.0f, -512.0f, 512.0f}, 65536.0f, SignalScale{1.0f},
                            SignalScale{512.0f})
                    .ok());
    for (int n = 0; n < 1000; ++n) {
        const double want = (0.3125 + 0.125 * (n + 1)) / 512.0;
        ASSERT_EQ(q.apply(Q31::from_double(0.25)).raw(), static_cast<int32_t>(want / kLsb)) << n;
    }
}

TEST(Pid, KdZeroMatchesShan2012GcWithPublishedTuning) {
    // Shan2012: Kp = 1.3, Ki = 40000 at 100 kHz. Step of 10 mV, 2000 samples.
    const PidConfig c{1.3f, 40000.0f, 0.0f, 1000.0f, -100.0f, 100.0f};
    const double kp = 1.3, ki_ts = 40000.0 / 1e5, E = 0.01;
    Pid<float> f;
    ASSERT_TRUE(f.configure(c, 1e5f, {}, {}).ok());
    const int n_max = 2000;
    for (int n = 0; n < n_max; ++n) {
        const double want = kp * E + ki_ts * E * (n + 1);
        // float: Kp and Ki Ts are rounded to float (2^-24 relative each) and
        // each of the n + 1 integrator additions rounds by <= 2^-24 |I|:
        // (n + 4) 2^-24 |u| bounds the sum.
        ASSERT_NEAR(f.apply(static_cast<float>(E)), want, (n + 4) * std::ldexp(1.0, -24) * std::fabs(want)) << n;
    }
    // Q31: 0.1 V error scale, 10 V output scale (u reaches 8 V).
    Pid<Q31> q;
    const SignalScale in{0.1f}, out{10.0f};
    ASSERT_TRUE(q.configure({1.3f, 40000.0f, 0.0f, 1000.0f, -10.0f, 10.0f}, 1e5f, in, out).ok());
    const Q31 e = Q31::from_double(E / in.full_scale);
    const double e_V = e.to_double() * in.full_scale;
    for (int n = 0; n < n_max; ++n) {
        const double want = (kp * e_V + ki_ts * e_V * (n + 1)) / out.full_scale;
        // Q31: Ki Ts in sample units (0.004) has a mantissa resolution of
        // 2^-39, relative 3.6e-10 after rounding, so the integral (< 1 full
        // scale) is off by < 1 LSB; the Q55 floor of each step adds 2^-24 LSB
        // per sample; the output rounds to +-0.5 LSB. Kp the same: 2 LSB.
        ASSERT_NEAR(q.apply(e).raw(), want / kLsb, 2.0) << n;
    }
}

// ---------------------------------------------------------------------------
// Derivative: step E from rest gives d[n] = (Kd / tau) E alpha^n,
// alpha = exp(-2 pi f_c Ts) (step-invariant discretisation).

TEST(Pid, FilteredDerivativeStepResponseIsAnalytic) {
    // The configuration is float: the reference uses the float-rounded Kd
    // (2e-5 is not representable; the difference is 2.5e-8 relative).
    const PidConfig c{0.0f, 0.0f, 2e-5f, 5e3f, -1.0f, 1.0f};
    const double kd = c.kd_s, fc = c.derivative_cutoff_Hz, rate = 1e5, E = 0.5;
    const double kd_tau = kd * kTwoPi * fc;  // 0.628
    const double alpha = std::exp(-kTwoPi * fc / rate);
    Pid<float> f;
    Pid<Q31> q;
    ASSERT_TRUE(f.configure(c, static_cast<float>(rate), {}, {}).ok());
    ASSERT_TRUE(q.configure(c, static_cast<float>(rate), {}, {}).ok());
    // Before the step: nothing.
    for (int n = 0; n < 10; ++n) {
        ASSERT_EQ(f.apply(0.0f), 0.0f);
        ASSERT_EQ(q.apply(Q31::from_raw(0)).raw(), 0);
    }
    const Q31 eq = Q31::from_double(E);
    double worst_f = 0.0, worst_q = 0.0;
    for (int n = 0; n < 100; ++n) {
        const double want = kd_tau * E * std::pow(alpha, n);
        // float: Kd/tau and 1 - alpha rounded to float (2^-24 relative each;
        // alpha^n then carries n 2^-24 (1 - alpha) relative), and ef rounds
        // by <= ulp(E)/2 per sample, an error the filter forgets at rate
        // alpha, so |ef error| <= 2^-25 E / (1 - alpha), times Kd/tau.
        const double tol_f = 4 * std::ldexp(1.0, -24) * kd_tau * E * (1.0 + n * (1.0 - alpha) + 1.0 / (1.0 - alpha));
        const double uf = f.apply(static_cast<float>(E));
        EXPECT_NEAR(uf, want, tol_f) << n;
        worst_f = std::max(worst_f, std::fabs(uf - want) / tol_f);
        // Q31: ef tracks with error feedback to within 1 LSB, coefficient
        // mantissas are relative 2^-30 or better, output rounds to 0.5 LSB:
        // 4 LSB.
        const double uq = q.apply(eq).raw();
        EXPECT_NEAR(uq, want / kLsb, 4.0) << n;
        worst_q = std::max(worst_q, std::fabs(uq - want / kLsb));
    }
    std::printf("derivative step: float worst %.2f of its tolerance, Q31 worst %.2f LSB (tol 4)\n", worst_f, worst_q);
    // Constant error: the derivative has died out completely (D(1) = 0).
    for (int n = 0; n < 2000; ++n) q.apply(eq);
    EXPECT_EQ(q.apply(eq).raw(), 0);
}

TEST(Pid, DerivativeAddsToProportionalAndIntegral) {
    // All three terms together against the double-precision law.
    const PidConfig c{0.8f, 5000.0f, 3e-5f, 8000.0f, -5.0f, 5.0f};
    Pid<float> f;
    ASSERT_TRUE(f.configure(c, 1e5f, {}, {}).ok());
    DoublePid d(c, 1e5);
    std::mt19937 rng(42);
    std::normal_distribution<double> noise(0.0, 0.2);
    for (int n = 0; n < 2000; ++n) {
        const double e = 0.5 * std::sin(n * 0.01) + noise(rng);
        const float ef = static_cast<float>(e);
        // float vs double on |u| <= 5: coefficient and per-operation rounding
        // at 2^-24 relative, integrator error growing by <= 2^-24 |I| per
        // sample; (n + 64) 2^-24 * 5 bounds both over these 2000 samples.
        EXPECT_NEAR(f.apply(ef), d.apply(ef), (n + 64) * std::ldexp(1.0, -24) * 5.0) << n;
    }
}

// ---------------------------------------------------------------------------
// Anti-windup: after a long saturation the output leaves saturation on the
// very sample the error changes sign; without anti-windup it stays saturated
// for thousands of samples.

namespace {

// A PID without anti-windup, computed here: the integrator runs free and only
// the output is clamped.
struct NoAntiWindup {
    double kp, ki_ts, u_min, u_max, i = 0.0;
    double apply(double e) {
        i += ki_ts * e;
        return std::clamp(kp * e + i, u_min, u_max);
    }
};

template <class T>
void check_anti_windup(double sign) {
    // kp 1, Ki 1e4 at 100 kHz, limits +-1 (full scale 2 for Q31).
    const PidConfig c{1.0f, 1e4f, 0.0f, 1000.0f, -1.0f, 1.0f};
    const SignalScale in{1.0f}, out{2.0f};
    Pid<T> pid;
    ASSERT_TRUE(pid.configure(c, 1e5f, in, out).ok());
    NoAntiWindup naive{1.0, 0.1, -1.0, 1.0};
    auto run = [&](double e) {
        double u;
        if constexpr (std::is_same_v<T, float>) {
            u = pid.apply(static_cast<float>(e));
        } else {
            u = pid.apply(Q31::from_double(e / in.full_scale)).to_double() * out.full_scale;
        }
        return u;
    };
    // Error 0.5 for 5000 samples (50 ms): the output saturates after ~10.
    double u = 0.0;
    for (int n = 0; n < 5000; ++n) u = run(sign * 0.5), naive.apply(sign * 0.5);
    EXPECT_EQ(u, sign * 1.0);
    EXPECT_EQ(pid.saturation(), sign > 0 ? 1 : -1);
    EXPECT_TRUE(pid.saturated());
    // The error changes sign: this very sample leaves saturation.
    u = run(-sign * 0.1);
    EXPECT_LT(sign * u, 1.0 - 0.05);
    EXPECT_EQ(pid.saturation(), 0);
    EXPECT_FALSE(pid.saturated());
    // The naive integrator holds 0.1 * 0.5 * 5000 = 250 and needs ~25000
    // samples of -0.1 error to unwind.
    int naive_saturated = 0;
    while (sign * naive.apply(-sign * 0.1) >= 1.0) ++naive_saturated;
    std::printf("anti-windup (%s, %s limit): leaves saturation after 0 samples; without: %d samples\n",
                std::is_same_v<T, float> ? "float" : "Q31", sign > 0 ? "upper" : "lower", naive_saturated);
    EXPECT_GT(naive_saturated, 20000);
    // And the integrator never exceeded what the output needed: 1 - kp*0.5.
    if constexpr (std::is_same_v<T, float>) {
        EXPECT_NEAR(pid.integrator(), sign * (0.5 - 0.01), 1e-6);
    } else {
        EXPECT_NEAR(pid.integrator().to_double() * out.full_scale, sign * (0.5 - 0.01), 1e-8);
    }
}

}  // namespace

TEST(Pid, AntiWindupLeavesSaturationWhenTheErrorChangesSignFloat) {
    check_anti_windup<float>(1.0);
    check_anti_windup<float>(-1.0);
}

TEST(Pid, AntiWindupLeavesSaturationWhenTheErrorChangesSignQ31) {
    check_anti_windup<Q31>(1.0);
    check_anti_windup<Q31>(-1.0);
}

TEST(Pid, IntegratorReachesTheLimitExactlyAndHolds) {
    // Clamping (not plain conditional integration): the output reaches u_max
    // exactly instead of stalling one integration step below it.
    Pid<float> f;
    ASSERT_TRUE(f.configure({0.0f, 3e4f, 0.0f, 1000.0f, -1.0f, 1.0f}, 1e5f, {}, {}).ok());
    float u = 0.0f;
    for (int n = 0; n < 20; ++n) u = f.apply(0.25f);  // 0.075 per sample
    EXPECT_EQ(u, 1.0f);
    EXPECT_EQ(f.integrator(), 1.0f);
}

// ---------------------------------------------------------------------------
// Q31 vs float on a long random error with saturation events.

TEST(Pid, Q31AgreesWithFloatAndDoubleLaw) {
    // Error in um (10 um full scale), output in V (150 V full scale).
    const PidConfig c{2.0f, 2000.0f, 1e-4f, 10000.0f, -20.0f, 120.0f};
    const SignalScale in{10.0f}, out{150.0f};
    Pid<float> f;
    Pid<Q31> q;
    ASSERT_TRUE(f.configure(c, 1e5f, in, out).ok());
    ASSERT_TRUE(q.configure(c, 1e5f, in, out).ok());
    DoublePid d(c, 1e5);
    std::mt19937 rng(2024);
    std::normal_distribution<double> noise(0.0, 0.3);
    double q_vs_d = 0.0, f_vs_d = 0.0, q_vs_f = 0.0;
    int saturated = 0;
    for (int n = 0; n < 50000; ++n) {
        const Q31 e = Q31::from_double((4.0 * std::sin(n * 2e-4) + noise(rng)) / in.full_scale);
        const double e_um = e.to_double() * in.full_scale;
        const double uq = q.apply(e).to_double() * out.full_scale;
        const double uf = f.apply(static_cast<float>(e_um));
        const double ud = d.apply(e_um);
        saturated += q.saturated() ? 1 : 0;
        q_vs_d = std::max(q_vs_d, std::fabs(uq - ud));
        f_vs_d = std::max(f_vs_d, std::fabs(uf - ud));
        q_vs_f = std::max(q_vs_f, std::fabs(uq - uf));
    }
    // The sequence drives both limits repeatedly (so the clamps are exercised).
    EXPECT_GT(saturated, 5000);
    // Q31 vs the double law: coefficients to 2^-30 relative or better,
    // the Q55 integrator floors 2^-24 LSB per sample (50000 samples: < 0.01
    // LSB), ef within 1 LSB times Kd/tau (~0.1 in sample units), output
    // rounding 0.5 LSB: 4 LSB of 150 V.
    const double q_tol = 4 * kLsb * out.full_scale;
    // float vs the double law: per-operation rounding at 2^-24 of |u| <= 120 V
    // plus the integrator's random walk of 2^-24 |I| per sample between
    // saturations (which re-anchor it to the limit). Bounded here by
    // 2^-24 * 120 V * 256 (~256 accumulated roundings; the expected random
    // walk over the longest unsaturated stretch is far below that).
    const double f_tol = std::ldexp(1.0, -24) * 120.0 * 256.0;
    EXPECT_LE(q_vs_d, q_tol);
    EXPECT_LE(f_vs_d, f_tol);
    EXPECT_LE(q_vs_f, q_tol + f_tol);
    std::printf("PID noise test: %d/50000 saturated; Q31-double %.2e V (tol %.1e), float-double %.2e V (tol %.1e), "
                "Q31-float %.2e V\n",
                saturated, q_vs_d, q_tol, f_vs_d, f_tol, q_vs_f);
}

// ---------------------------------------------------------------------------
// configure: every field is checked and named; nothing changes on rejection.

namespace {

template <class T>
void check_pid_rejections() {
    const PidConfig good{1.0f, 1000.0f, 1e-5f, 5000.0f, -1.0f, 1.0f};
    const SignalScale in{1.0f}, out{1.0f};
    Pid<T> a, ref;
    ASSERT_TRUE(a.configure(good, 1e5f, in, out).ok());
    ASSERT_TRUE(ref.configure(good, 1e5f, in, out).ok());
    auto x = [](int n) { return 0.3 * std::sin(n * 0.05); };
    auto sample = [](double v) {
        if constexpr (std::is_same_v<T, float>) return static_cast<float>(v); else return Q31::from_double(v);
    };
    for (int n = 0; n < 100; ++n) {
        a.apply(sample(x(n)));
        ref.apply(sample(x(n)));
    }
    const float nan = std::nanf(""), inf = HUGE_VALF;
    struct Case {
        PidConfig c;
        float rate;
        SignalScale i, o;
        const char* field;
    };
    auto with = [&](auto mutate) {
        PidConfig c = good;
        mutate(c);
        return c;
    };
    const Case cases[] = {
        {good, 0.0f, in, out, "sample_rate_Hz"},
        {good, nan, in, out, "sample_rate_Hz"},
        {with([](PidConfig& c) { c.kp = -1.0f; }), 1e5f, in, out, "kp"},
        {with([&](PidConfig& c) { c.kp = nan; }), 1e5f, in, out, "kp"},
        {with([&](PidConfig& c) { c.ki_per_s = inf; }), 1e5f, in, out, "ki_per_s"},
        {with([](PidConfig& c) { c.kd_s = -1e-6f; }), 1e5f, in, out, "kd_s"},
        {with([](PidConfig& c) { c.derivative_cutoff_Hz = 0.0f; }), 1e5f, in, out, "derivative_cutoff_Hz"},
        {with([](PidConfig& c) { c.derivative_cutoff_Hz = 5e4f; }), 1e5f, in, out, "derivative_cutoff_Hz"},
        {with([&](PidConfig& c) { c.derivative_cutoff_Hz = nan; }), 1e5f, in, out, "derivative_cutoff_Hz"},
        {with([&](PidConfig& c) { c.u_min = -inf; }), 1e5f, in, out, "u_min"},
        {with([](PidConfig& c) { c.u_max = -1.0f; }), 1e5f, in, out, "u_max"},
        {with([&](PidConfig& c) { c.u_max = nan; }), 1e5f, in, out, "u_max"},
        {good, 1e5f, SignalScale{0.0f}, out, "in.full_scale"},
        {good, 1e5f, in, SignalScale{nan}, "out.full_scale"},
    };
    for (const Case& k : cases) {
        const Status s = a.configure(k.c, k.rate, k.i, k.o);
        ASSERT_FALSE(s.ok()) << k.field;
        EXPECT_STREQ(s.field, k.field);
        EXPECT_NE(s.message, nullptr);
    }
    if constexpr (std::is_same_v<T, Q31>) {
        // Q31-only ranges: sample-unit gains and limits within the output scale.
        const Case q31_cases[] = {
            {with([](PidConfig& c) { c.kp = 100.0f; }), 1e5f, in, out, "kp"},
            {with([](PidConfig& c) { c.ki_per_s = 1e7f; }), 1e5f, in, out, "ki_per_s"},
            {with([](PidConfig& c) { c.kd_s = 1e-2f; }), 1e5f, in, out, "kd_s"},
            {with([](PidConfig& c) { c.u_min = -1.5f; }), 1e5f, in, out, "u_min"},
            {with([](PidConfig& c) { c.u_max = 1.5f; }), 1e5f, in, out, "u_max"},
        };
        for (const Case& k : q31_cases) {
            const Status s = a.configure(k.c, k.rate, k.i, k.o);
            ASSERT_FALSE(s.ok()) << k.field;
            EXPECT_STREQ(s.field, k.field);
        }
        // The same gain is fine with a 10x larger output scale.
        Pid<Q31> other;
        EXPECT_TRUE(other.configure(with([](PidConfig& c) { c.kp = 100.0f; }), 1e5f, in, SignalScale{10.0f}).ok());
    }
    for (int n = 100; n < 300; ++n) ASSERT_EQ(a.apply(sample(x(n))), ref.apply(sample(x(n)))) << n;
}

}  // namespace

TEST(Pid, FloatConfigureRejectsNamingTheFieldAndKeepsEverything) { check_pid_rejections<float>(); }
TEST(Pid, Q31ConfigureRejectsNamingTheFieldAndKeepsEverything) { check_pid_rejections<Q31>(); }

TEST(Pid, ResetClearsStateAndReconfigureClampsTheIntegrator) {
    Pid<float> f;
    ASSERT_TRUE(f.configure({0.0f, 1e4f, 0.0f, 1000.0f, -2.0f, 2.0f}, 1e5f, {}, {}).ok());
    for (int n = 0; n < 100; ++n) f.apply(1.0f);
    EXPECT_EQ(f.integrator(), 2.0f);
    // Narrower limits: the integrator is pulled inside at once.
    ASSERT_TRUE(f.configure({0.0f, 1e4f, 0.0f, 1000.0f, -0.5f, 0.5f}, 1e5f, {}, {}).ok());
    EXPECT_EQ(f.integrator(), 0.5f);
    f.reset();
    EXPECT_EQ(f.integrator(), 0.0f);
    EXPECT_EQ(f.saturation(), 0);
    EXPECT_FLOAT_EQ(f.apply(0.1f), 0.01f);
}
