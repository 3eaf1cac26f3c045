// Excitation generator (excitation.hpp) against independent computations in
// long double: the multisine's DFT, Schroeder's crest factor, the PRBS's
// period and balance, the sweep's phase and instantaneous frequency; and its
// hook in the pipeline (d added at the command or the reference, clipping
// counted, nothing changed once it has finished).
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <complex>
#include <cstdint>
#include <memory>
#include <numbers>
#include <vector>

#include "piezoloop/excitation.hpp"
#include "piezoloop/pipeline.hpp"

using namespace piezoloop;

namespace {

constexpr long double kTwoPi = 2.0L * std::numbers::pi_v<long double>;

template <class T, std::size_t Cap>
std::vector<long double> one_period(ExcitationGenerator<T, Cap>& g, uint32_t n) {
    std::vector<long double> x(n);
    for (uint32_t i = 0; i < n; ++i) {
        const T v = g.step();
        if constexpr (std::is_same_v<T, float>) x[i] = v;
        else x[i] = v.to_double();
    }
    return x;
}

std::complex<long double> dft_bin(const std::vector<long double>& x, uint32_t k) {
    const uint64_t n = x.size();
    std::complex<long double> acc = 0.0L;
    for (uint64_t i = 0; i < n; ++i) {
        const long double a = -kTwoPi * static_cast<long double>((k * i) % n) / static_cast<long double>(n);
        acc += x[i] * std::complex<long double>(std::cos(a), std::sin(a));
    }
    return acc;
}

ExcitationConfig multisine(uint32_t n, uint32_t k1, uint32_t k2, float amplitude) {
    ExcitationConfig c;
    c.signal = ExcitationSignal::kMultisine;
    c.period_samples = n;
    c.first_bin = k1;
    c.last_bin = k2;
    c.amplitude = amplitude;
    c.sample_rate_Hz = 10000.0f;
    return c;
}

}  // namespace

TEST(Excitation, MultisineHasItsEnergyOnTheChosenBinsOnly) {
    constexpr uint32_t N = 512, k1 = 5, k2 = 60;
    auto g = std::make_unique<ExcitationGenerator<float, 1024>>();
    ASSERT_TRUE(g->configure(multisine(N, k1, k2, 2.0f)).ok());
    const std::vector<long double> x = one_period(*g, N);
    long double line = 0.0L;
    for (uint32_t k = k1; k <= k2; ++k) line += std::abs(dft_bin(x, k));
    line /= (k2 - k1 + 1);
    for (uint32_t k = 0; k <= N / 2; ++k) {
        const long double m = std::abs(dft_bin(x, k));
        if (k >= k1 && k <= k2) {
            // Equal amplitudes (sine table, Q31 rounding, float scaling: ~1e-6).
            EXPECT_NEAR(m / line, 1.0L, 2e-5L) << "bin " << k;
        } else {
            EXPECT_LT(m / line, 2e-5L) << "bin " << k;
        }
    }
    // Schroeder's phases, relative to the first line: phi_j = -pi j (j + 1) / K.
    const long double K = k2 - k1 + 1;
    const std::complex<long double> x0 = dft_bin(x, k1);
    for (uint32_t j = 1; j < K; ++j) {
        const std::complex<long double> r = dft_bin(x, k1 + j) / x0;
        const long double want = -std::numbers::pi_v<long double> * j * (j + 1) / K;
        const long double d = std::remainder(std::arg(r) - want, kTwoPi);
        EXPECT_LT(std::fabs(d), 1e-4L) << "line " << j;
    }
    // It repeats exactly.
    const std::vector<long double> x2 = one_period(*g, N);
    EXPECT_EQ(x, x2);
}

TEST(Excitation, SchroederPhasesGiveALowCrestFactor) {
    // Crest factor peak / rms of K equal lines: sqrt(2K) with equal phases;
    // Schroeder's phases keep it near 1.7 (Pintelon & Schoukens 2012, ch. 5).
    for (const uint32_t K : {10u, 50u, 200u}) {
        const uint32_t N = 1024;
        auto g = std::make_unique<ExcitationGenerator<float, 1024>>();
        ASSERT_TRUE(g->configure(multisine(N, 1, K, 1.0f)).ok());
        const std::vector<long double> x = one_period(*g, N);
        long double peak = 0.0L, sq = 0.0L;
        for (const long double v : x) {
            peak = std::max(peak, std::fabs(v));
            sq += v * v;
        }
        const long double crest = peak / std::sqrt(sq / N);
        EXPECT_NEAR(static_cast<double>(peak), 1.0, 1e-6) << K;  // normalised to the amplitude
        EXPECT_LT(crest, 2.0L) << K;
        EXPECT_GT(crest, 1.35L) << K;
        // The same sum evaluated in long double gives the same crest factor.
        long double peak_ref = 0.0L, sq_ref = 0.0L;
        for (uint32_t n = 0; n < N; ++n) {
            long double s = 0.0L;
            for (uint32_t j = 0; j < K; ++j)
                s += std::cos(kTwoPi * ((j + 1.0L) * n / N) - std::numbers::pi_v<long double> * j * (j + 1) / K);
            peak_ref = std::max(peak_ref, std::fabs(s));
            sq_ref += s * s;
        }
        EXPECT_NEAR(static_cast<double>(crest), static_cast<double>(peak_ref / std::sqrt(sq_ref / N)), 1e-4) << K;
    }
}

TEST(Excitation, FloatAndQ31MultisinesAreTheSameShape) {
    auto gf = std::make_unique<ExcitationGenerator<float, 256>>();
    auto gq = std::make_unique<ExcitationGenerator<Q31, 256>>(SignalScale{10.0f});
    ExcitationConfig c = multisine(200, 2, 30, 3.0f);
    c.offset = 1.5f;
    ASSERT_TRUE(gf->configure(c).ok());
    ASSERT_TRUE(gq->configure(c).ok());
    for (int i = 0; i < 400; ++i) {
        const float f = gf->step();
        const float q = gq->step().to_float() * 10.0f;
        EXPECT_NEAR(f, q, 1e-6f) << i;
    }
}

TEST(Excitation, PrbsIsMaximumLengthAndBalanced) {
    for (uint32_t order = 2; order <= 24; ++order) {
        ExcitationConfig c;
        c.signal = ExcitationSignal::kPrbs;
        c.prbs_order = order;
        c.amplitude = 1.0f;
        ExcitationGenerator<float, 4> g;
        ASSERT_TRUE(g.configure(c).ok()) << order;
        const uint32_t period = (1u << order) - 1u;
        ASSERT_EQ(g.period_length(), period);
        // Every non-zero n-bit window occurs exactly once per period: the
        // sequence is maximum length (a shorter cycle would repeat one).
        std::vector<bool> seen(std::size_t{1} << order, false);
        uint32_t window = 0, ones = 0;
        std::vector<bool> bits;
        bits.reserve(period + order);
        for (uint32_t i = 0; i < period + order; ++i) bits.push_back(g.step() > 0.0f);
        for (uint32_t i = 0; i < period; ++i) ones += bits[i] ? 1u : 0u;
        for (uint32_t i = 0; i < order - 1; ++i) window = (window << 1) | (bits[i] ? 1u : 0u);
        const uint32_t mask = period;
        uint32_t distinct = 0;
        for (uint32_t i = order - 1; i < period + order - 1; ++i) {
            window = ((window << 1) | (bits[i] ? 1u : 0u)) & mask;
            ASSERT_NE(window, 0u) << order;
            if (!seen[window]) ++distinct;
            seen[window] = true;
        }
        EXPECT_EQ(distinct, period) << order;
        EXPECT_EQ(ones, 1u << (order - 1)) << order;  // balance: one more one than zeros
        for (uint32_t i = 0; i < order; ++i) EXPECT_EQ(bits[i], bits[period + i]) << order;
    }
}

TEST(Excitation, PrbsHoldsEachBit) {
    ExcitationConfig c;
    c.signal = ExcitationSignal::kPrbs;
    c.prbs_order = 5;
    c.prbs_hold = 3;
    c.amplitude = 2.0f;
    c.offset = 1.0f;
    c.periods = 1;
    ExcitationGenerator<float, 4> g;
    ASSERT_TRUE(g.configure(c).ok());
    ASSERT_EQ(g.period_length(), 93u);
    for (int b = 0; b < 31; ++b) {
        const float v = g.step();
        EXPECT_TRUE(v == 3.0f || v == -1.0f);
        EXPECT_EQ(g.step(), v);
        EXPECT_EQ(g.step(), v);
    }
    EXPECT_TRUE(g.done());
    EXPECT_EQ(g.step(), 1.0f);  // the offset after the last period
}

TEST(Excitation, SweepFollowsTheLogarithmicLaw) {
    constexpr float fs = 10000.0f, f1 = 10.0f, f2 = 2000.0f;
    constexpr uint32_t L = 20000;
    ExcitationConfig c;
    c.signal = ExcitationSignal::kSweep;
    c.sample_rate_Hz = fs;
    c.f1_Hz = f1;
    c.f2_Hz = f2;
    c.period_samples = L;
    c.amplitude = 1.0f;
    ExcitationGenerator<float, 4> g;
    ASSERT_TRUE(g.configure(c).ok());
    // Instantaneous frequency f1 (f2/f1)^(n/L): the phase is the sum of the
    // increments, f1/fs (r^n - 1)/(r - 1) cycles with r = (f2/f1)^(1/L).
    const long double r = std::pow(static_cast<long double>(f2) / f1, 1.0L / L);
    long double max_err = 0.0L;
    std::vector<long double> x(L);
    for (uint32_t n = 0; n < L; ++n) {
        x[n] = g.step();
        const long double ph = static_cast<long double>(f1) / fs * (std::pow(r, n) - 1.0L) / (r - 1.0L);
        max_err = std::max(max_err, std::fabs(x[n] - std::sin(kTwoPi * ph)));
    }
    EXPECT_LT(max_err, 2e-6L);
    // Zero crossings: the time between rising crossings is one period of the
    // instantaneous frequency at their midpoint (to the curvature of the law);
    // the phase check above covers the rest of the band.
    int checked = 0;
    std::vector<long double> crossings;
    for (uint32_t n = 1; n < L; ++n)
        if (x[n - 1] < 0.0L && x[n] >= 0.0L) crossings.push_back(n - 1 + (-x[n - 1]) / (x[n] - x[n - 1]));
    for (std::size_t i = 1; i + 1 < crossings.size(); i += 7) {
        const long double mid = 0.5L * (crossings[i] + crossings[i - 1]);
        const long double f_meas = fs / (crossings[i] - crossings[i - 1]);
        const long double f_law = f1 * std::pow(static_cast<long double>(f2) / f1, mid / L);
        // Linear interpolation of the crossings needs >= 20 samples per cycle.
        if (f_law > fs / 20.0f) break;
        EXPECT_NEAR(static_cast<double>(f_meas / f_law), 1.0, 2e-3) << "at sample " << static_cast<double>(mid);
        ++checked;
    }
    EXPECT_GT(checked, 20);
}

// Step, triangle and raised cosine against their definitions in long double:
// w(n) = 0 / 1 at n < / >= N/2; 1 - |1 - 2n/N|; (1 - cos 2 pi n/N) / 2. The
// generator's phase is floor(n 2^32 / N), so its error is the phase's
// truncation (< 2^-32 of a cycle: ~1.5e-9 of the amplitude for the
// triangle, its slope being 2) plus the sine table's 2.95e-7 and one Q31
// step, and the step is exact.
TEST(Excitation, StepTriangleAndRaisedCosineFollowTheirDefinitions) {
    constexpr uint32_t N = 1000;
    for (const ExcitationSignal sig : {ExcitationSignal::kStep, ExcitationSignal::kTriangle,
                                       ExcitationSignal::kRaisedCosine}) {
        ExcitationConfig c;
        c.signal = sig;
        c.period_samples = N;
        c.amplitude = -2.0f;  // inverted: from the offset down
        c.offset = 5.0f;
        c.periods = 2;
        c.sample_rate_Hz = 10000.0f;
        auto g = std::make_unique<ExcitationGenerator<Q31, 4>>(SignalScale{16.0f});
        ASSERT_TRUE(g->configure(c).ok());
        double worst = 0.0;
        for (uint32_t p = 0; p < 2; ++p) {
            for (uint32_t n = 0; n < N; ++n) {
                const long double x = static_cast<long double>(n) / N;
                const long double w = sig == ExcitationSignal::kStep       ? (2 * n >= N ? 1.0L : 0.0L)
                                      : sig == ExcitationSignal::kTriangle ? 1.0L - std::fabs(1.0L - 2.0L * x)
                                                                           : 0.5L * (1.0L - std::cos(kTwoPi * x));
                const double want = static_cast<double>(5.0L - 2.0L * w);
                worst = std::max(worst, std::fabs(g->step().to_double() * 16.0 - want));
            }
        }
        EXPECT_LT(worst, 16.0 * 4e-7) << static_cast<int>(sig);
        EXPECT_TRUE(g->done());
        EXPECT_NEAR(g->step().to_double() * 16.0, 5.0, 1e-8);  // back at the offset
    }
}

TEST(Excitation, RefusesWhatItCannotGenerate) {
    ExcitationGenerator<float, 64> g;
    EXPECT_EQ(std::string(g.configure(multisine(128, 1, 10, 1.0f)).field), "period_samples");
    EXPECT_EQ(std::string(g.configure(multisine(64, 0, 10, 1.0f)).field), "last_bin");
    EXPECT_EQ(std::string(g.configure(multisine(64, 1, 32, 1.0f)).field), "last_bin");
    EXPECT_EQ(std::string(g.configure(multisine(64, 1, 10, NAN)).field), "amplitude");
    ExcitationConfig s;
    s.signal = ExcitationSignal::kSweep;
    s.sample_rate_Hz = 1000.0f;
    s.period_samples = 100;
    s.f1_Hz = 10.0f;
    s.f2_Hz = 500.0f;
    EXPECT_EQ(std::string(g.configure(s).field), "f2_Hz");
    ExcitationConfig p;
    p.signal = ExcitationSignal::kPrbs;
    p.prbs_order = 25;
    EXPECT_EQ(std::string(g.configure(p).field), "prbs_order");
    EXPECT_FALSE(g.configured());
}

// Every size and count the excitation takes, at the boundaries near 2^31
// and 2^32 where 32-bit arithmetic wraps: a multisine's last bin must stay
// below N / 2 (2 k2 = 2^32 + 2 j would wrap to 2 j < N, admitting 2^31
// lines above Nyquist for the main loop to tabulate), and a PRBS period
// (2^n - 1) h must fit the 32-bit sample counter. Refused at once, naming
// the field; the largest accepted values still work.
TEST(Excitation, SizesNearTwoToThe31And32AreCheckedWithoutWrapping) {
    ExcitationGenerator<float, 1024> g;
    for (const uint32_t n : {4u, 5u, 1000u, 1001u, 1023u, 1024u}) {
        const uint32_t top = (n - 1u) / 2u;  // the last bin below N / 2
        for (const uint32_t k2 : {top + 1u, n / 2u + 1u, 0x7fffffffu, 0x80000000u, 0x80000001u,
                                  0x80000000u + top, 0x80000000u + n / 2u - 1u, 0xfffffffeu, 0xffffffffu}) {
            if (2ull * k2 < n) continue;
            const Status s = g.configure(multisine(n, 1, k2, 1.0f));
            ASSERT_FALSE(s.ok()) << n << " " << k2;
            EXPECT_STREQ(s.field, "last_bin") << n << " " << k2;
        }
        EXPECT_STREQ(g.configure(multisine(n, 0x80000000u, 0x80000000u, 1.0f)).field, "last_bin");
        ASSERT_TRUE(g.configure(multisine(n, 1, top, 1.0f)).ok()) << n;
        EXPECT_EQ(g.period_length(), n);
    }
    EXPECT_STREQ(g.configure(multisine(1025, 1, 2, 1.0f)).field, "period_samples");
    EXPECT_STREQ(g.configure(multisine(0x80000000u, 1, 2, 1.0f)).field, "period_samples");
    EXPECT_STREQ(g.configure(multisine(0xffffffffu, 1, 2, 1.0f)).field, "period_samples");

    // PRBS: for every order the longest hold whose period fits, and one more.
    for (uint32_t order = 2; order <= 24; ++order) {
        const uint64_t bits = (uint64_t{1} << order) - 1u;
        const uint64_t fits = std::min<uint64_t>(0xffffffffull / bits, 65536u);
        ExcitationConfig p;
        p.signal = ExcitationSignal::kPrbs;
        p.sample_rate_Hz = 10000.0f;
        p.amplitude = 1.0f;
        p.prbs_order = order;
        p.prbs_hold = static_cast<uint32_t>(fits);
        ASSERT_TRUE(g.configure(p).ok()) << order;
        EXPECT_EQ(uint64_t{g.period_length()}, bits * fits) << order;
        if (fits < 65536u) {
            p.prbs_hold = static_cast<uint32_t>(fits + 1u);
            EXPECT_STREQ(g.configure(p).field, "prbs_hold") << order;
        }
    }
}

namespace {

PipelineSetup open_loop_setup() {
    PipelineSetup s;
    s.rate_Hz = 10000.0f;
    s.hard = {-2.0f, 12.0f, 1.0e6f};
    s.voltage = SignalScale{16.0f};
    s.position = SignalScale{40.0f};
    return s;
}

PipelineParams open_loop_params() {
    PipelineParams p;
    p.limits = {-2.0f, 12.0f, 1.0e6f, 0.0f};
    return p;
}

}  // namespace

TEST(ExcitationInPipeline, OpenLoopCommandIsBiasPlusExcitation) {
    auto pipe = std::make_unique<Pipeline<float>>(open_loop_setup());
    ASSERT_TRUE(pipe->stage(open_loop_params()).ok());
    pipe->arm();
    ExcitationConfig c = multisine(100, 1, 20, 0.5f);
    c.offset = 3.0f;
    c.periods = 2;
    ExcitationGenerator<float, 1024> ref;
    ASSERT_TRUE(ref.configure(c).ok());
    for (int i = 0; i < 10; ++i) EXPECT_EQ(pipe->tick(0.0f), 0.0f);  // open loop, no excitation: 0 V
    ASSERT_TRUE(pipe->start_excitation(c).ok());
    EXPECT_FALSE(pipe->start_excitation(c).ok());  // one at a time
    // The lead-in (lead_in.hpp) from the command in effect (0 V) to the
    // bias: 3 V at the speed bound (10 full scales of 16 V a second) would
    // take 563 ticks, so it is capped at a quarter of the 100-sample period.
    // Its samples are 0 + (d - 0) s(n / 25), s(x) = 10x^3 - 15x^4 + 6x^5 in
    // double here; tolerance 2e-6 V: the core's s is Q31 integer arithmetic
    // within 2^-26 of the polynomial, times |d| < 4 V, plus float rounding.
    // From then on u is d exactly.
    for (int i = 0; i < 200; ++i) {
        const float u = pipe->tick(0.0f);
        const float d = ref.step();
        if (i == 0) {
            EXPECT_EQ(pipe->excitation_lead_in_ticks(), 25u);
        }
        if (i < 25) {
            const double x = i / 25.0;
            const double s = x * x * x * (10.0 - 15.0 * x + 6.0 * x * x);
            EXPECT_NEAR(u, d * s, 2e-6) << i;
            EXPECT_EQ(pipe->excitation_sample(), u);  // d as recorded: the blended one
        } else {
            EXPECT_EQ(u, d) << i;
            EXPECT_EQ(pipe->excitation_sample(), d);
        }
    }
    EXPECT_FALSE(pipe->excitation_running());
    EXPECT_EQ(pipe->excitation_ticks(), 200u);
    EXPECT_EQ(pipe->excitation_clipped_samples(), 0u);
    EXPECT_EQ(pipe->tick(0.0f), 0.0f);  // back to the controller's (zero) output
}

// Within the range but faster than the slew limit: the limiter shapes d and
// every tick it changed is counted; the output never moves faster than the
// limit nor leaves the range.
TEST(ExcitationInPipeline, ClippingIsCountedAndTheLimitsStillHold) {
    auto pipe = std::make_unique<Pipeline<Q31>>(open_loop_setup());
    PipelineParams p = open_loop_params();
    p.limits.slew_V_per_s = 2000.0f;  // 0.2 V per tick at 10 kHz
    ASSERT_TRUE(pipe->stage(p).ok());
    pipe->arm();
    ExcitationConfig c = multisine(100, 1, 20, 4.0f);
    c.offset = 6.0f;  // 2 .. 10 V, within [-2, 12] V
    c.periods = 1;
    c.sample_rate_Hz = 10000.0f;
    for (int i = 0; i < 40; ++i) (void)pipe->tick(Q31{});  // slew up to the bias
    ASSERT_TRUE(pipe->start_excitation(c).ok());
    float last = pipe->last().u.to_float() * 16.0f;
    uint32_t limited = 0;
    for (int i = 0; i < 100; ++i) {
        const float u = pipe->tick(Q31{}).to_float() * 16.0f;
        EXPECT_LE(u, 12.0f + 1e-5f);
        EXPECT_GE(u, -2.0f - 1e-5f);
        EXPECT_LE(std::fabs(u - last), 0.2f + 1e-4f) << i;
        if (std::fabs(u - last) >= 0.2f - 1e-4f) ++limited;
        last = u;
    }
    EXPECT_GT(pipe->excitation_clipped_samples(), 0u);
    EXPECT_GE(pipe->excitation_clipped_samples(), limited);
}

// A command that would leave the limits group's range is refused before it
// starts: open loop the whole of offset +- amplitude, closed loop (a
// feedback configured) the span of d. Nothing starts.
TEST(ExcitationInPipeline, RefusesACommandBeyondTheLimits) {
    auto pipe = std::make_unique<Pipeline<float>>(open_loop_setup());
    ASSERT_TRUE(pipe->stage(open_loop_params()).ok());  // [-2, 12] V
    ExcitationConfig c = multisine(100, 1, 20, 4.0f);
    c.offset = 9.0f;  // 5 .. 13 V
    Status s = pipe->start_excitation(c);
    EXPECT_FALSE(s.ok());
    EXPECT_STREQ(s.field, "amplitude");
    EXPECT_FALSE(pipe->excitation_running());
    c.offset = 8.0f;  // 4 .. 12 V
    EXPECT_TRUE(pipe->start_excitation(c).ok());
    pipe->stop_excitation();
    (void)pipe->tick(0.0f);

    // Closed loop: d alone may be bipolar, but not wider than the range.
    PipelineParams p = open_loop_params();
    p.feedback = FeedbackKind::kPid;
    p.pid.kp = 0.1f;
    p.pid.derivative_cutoff_Hz = 1000.0f;
    p.pid.u_min = -2.0f;
    p.pid.u_max = 12.0f;
    ASSERT_TRUE(pipe->stage(p).ok());
    c.offset = 0.0f;
    c.amplitude = 7.0f;  // span 14 V = the range
    EXPECT_TRUE(pipe->start_excitation(c).ok());
    pipe->stop_excitation();
    (void)pipe->tick(0.0f);
    c.amplitude = 7.5f;
    EXPECT_FALSE(pipe->start_excitation(c).ok());
}

TEST(ExcitationInPipeline, ReferencePointAddsToTheSetpointAndStops) {
    auto pipe = std::make_unique<Pipeline<float>>(open_loop_setup());
    ASSERT_TRUE(pipe->stage(open_loop_params()).ok());
    pipe->set_setpoint(5.0f);
    pipe->arm();
    ExcitationConfig c = multisine(64, 1, 10, 1.0f);
    c.point = ExcitationPoint::kReference;
    ExcitationGenerator<float, 1024> ref;
    ASSERT_TRUE(ref.configure(c).ok());
    ASSERT_TRUE(pipe->start_excitation(c).ok());
    for (int i = 0; i < 100; ++i) {
        (void)pipe->tick(0.0f);
        EXPECT_EQ(pipe->last().r, 5.0f + ref.step()) << i;
    }
    pipe->stop_excitation();
    (void)pipe->tick(0.0f);  // the tick that takes the stop still carries d
    EXPECT_FALSE(pipe->excitation_running());
    (void)pipe->tick(0.0f);
    EXPECT_EQ(pipe->last().r, 5.0f);
    EXPECT_EQ(pipe->last().u, 0.0f);
}

TEST(ExcitationInPipeline, AReferenceOffsetLeadsInFromTheSetpoint) {
    // A step at the reference whose level is 2 µm above the held setpoint
    // (a closed-loop step measured from another point): r moves there along
    // the lead-in's minimum-jerk path instead of jumping, starting at the
    // setpoint itself, and is the setpoint plus d once it ends.
    auto pipe = std::make_unique<Pipeline<float>>(open_loop_setup());
    ASSERT_TRUE(pipe->stage(open_loop_params()).ok());
    pipe->set_setpoint(5.0f);
    pipe->arm();
    ExcitationConfig c;
    c.signal = ExcitationSignal::kStep;
    c.period_samples = 400;
    c.amplitude = 1.0f;
    c.offset = 2.0f;  // held at 2 µm, then 3 µm
    c.point = ExcitationPoint::kReference;
    c.sample_rate_Hz = 10000.0f;
    ExcitationGenerator<float, 1024> ref;
    ref.set_output_scale(open_loop_setup().position);
    ASSERT_TRUE(ref.configure(c).ok());
    ASSERT_TRUE(pipe->start_excitation(c).ok());
    float prev = 5.0f;
    for (int i = 0; i < 400; ++i) {
        (void)pipe->tick(0.0f);
        const float d = ref.step();
        const float r = pipe->last().r;
        if (i == 0) {
            // 2 µm with a peak speed of 10 full scales of 40 µm a second
            // takes ceil(2 / (8/15 x 400 µm/s / 10 kHz)) = 94 ticks, within
            // the cap of 100 (a quarter period).
            EXPECT_EQ(pipe->excitation_lead_in_ticks(), 94u);
            EXPECT_EQ(r, 5.0f);
        }
        if (i < 94) {
            EXPECT_GE(r, prev) << i;  // rises monotonically, no overshoot
            EXPECT_LE(r, 7.0f) << i;
            // No step beyond the speed bound's (2/94 x 15/8 µm a tick at most).
            EXPECT_LE(r - prev, 2.0f / 94.0f * 15.0f / 8.0f + 1e-5f) << i;
        } else {
            EXPECT_EQ(r, 5.0f + d) << i;
        }
        prev = r;
    }
}

TEST(ExcitationInPipeline, AQ31ExcitationLeadsInAsTheFloatOne) {
    // The open-loop multisine about 3 V of OpenLoopCommandIsBiasPlusExcitation
    // in both pipelines: the same lead-in length, and commands within 1e-5 V
    // (Q31 LSBs of 16 V, 7e-9 V, and the blend's rounding, far below it).
    auto f = std::make_unique<Pipeline<float>>(open_loop_setup());
    auto q = std::make_unique<Pipeline<Q31>>(open_loop_setup());
    ASSERT_TRUE(f->stage(open_loop_params()).ok());
    ASSERT_TRUE(q->stage(open_loop_params()).ok());
    f->arm();
    q->arm();
    ExcitationConfig c = multisine(100, 1, 20, 0.5f);
    c.offset = 3.0f;
    c.periods = 1;
    (void)f->tick(0.0f);
    (void)q->tick(Q31{});
    ASSERT_TRUE(f->start_excitation(c).ok());
    ASSERT_TRUE(q->start_excitation(c).ok());
    const SignalScale v = open_loop_setup().voltage;
    for (int i = 0; i < 100; ++i) {
        const float uf = f->tick(0.0f);
        const float uq = v.to_physical(q->tick(Q31{}));
        EXPECT_NEAR(uq, uf, 1e-5) << i;
    }
    EXPECT_EQ(q->excitation_lead_in_ticks(), f->excitation_lead_in_ticks());
    EXPECT_EQ(f->excitation_lead_in_ticks(), 25u);
}
