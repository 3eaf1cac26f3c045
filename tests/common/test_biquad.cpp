// Biquad cascade (float delta-operator sections with compensated states, Q31
// DF1 with error feedback) against scipy (tools/ref/biquad_ref.py ->
// tests/golden/biquad_ref.json). Stiff sections in float:
// test_biquad_stiff.cpp.
#include <gtest/gtest.h>

#include <cmath>
#include <array>
#include <complex>
#include <cstring>
#include <stdexcept>
#include <algorithm>
#include <cstdio>
#include <fstream>
#include <nlohmann/json.hpp>
#include <random>
#include <string>
#include <vector>

#include "piezoloop/biquad.hpp"

using namespace piezoloop;

namespace {

constexpr double kTwoPi = 6.283185307179586476925;
constexpr double kLsb = 1.0 / 2147483648.0;  // one Q31 LSB in full-scale units

const nlohmann::json& golden() {
    static const nlohmann::json j = [] {
        std::ifstream f(std::string(PIEZOLOOP_GOLDEN_DIR) + "/biquad_ref.json");
        return nlohmann::json::parse(f);
    }();
    return j;
}

std::vector<SosSection> sos_from(const nlohmann::json& rows) {
    std::vector<SosSection> out;
    for (const auto& r : rows)
        out.push_back({r[0].get<double>(), r[1].get<double>(), r[2].get<double>(), r[3].get<double>(),
                       r[4].get<double>()});
    return out;
}

std::vector<double> vec(const nlohmann::json& j) { return j.get<std::vector<double>>(); }

// Steady-state complex gain at frequency f: run `settle` samples of a cosine,
// then correlate `window` samples (a whole number of periods) with e^{-jwn}.
// For y = A |H| cos(wn + phi): sum y e^{-jwn} = (window A / 2) H.
template <class Step>
std::complex<double> measure_gain(Step&& step, double f_Hz, double fs, double amplitude, int settle, int window) {
    const double w = kTwoPi * f_Hz / fs;
    std::complex<double> acc = 0.0;
    for (int n = 0; n < settle + window; ++n) {
        const double y = step(amplitude * std::cos(w * n));
        if (n >= settle) acc += y * std::polar(1.0, -w * n);
    }
    return acc * (2.0 / (window * amplitude));
}

}  // namespace

// ---------------------------------------------------------------------------
// float cascade vs scipy, well-conditioned filters

TEST(BiquadFloat, ImpulseResponseMatchesScipySosfilt) {
    for (const auto& c : golden()["filters"]) {
        const auto sos = sos_from(c["sos"]);
        BiquadCascade<float, 4> f;
        ASSERT_TRUE(f.configure(sos.data(), static_cast<int>(sos.size()), {}, {}).ok()) << c["name"];
        const auto h = vec(c["impulse"]);
        const double l1 = c["impulse_l1"].get<double>();
        double worst = 0.0;
        for (size_t n = 0; n < h.size(); ++n) {
            const double y = f.apply(n == 0 ? 1.0f : 0.0f);
            worst = std::max(worst, std::fabs(y - h[n]));
        }
        // Float coefficients and state carry 2^-24 relative rounding per
        // operation (~10 per section); the error a rounding makes is at most
        // its size times the L1 norm of the response from that node, bounded
        // by the filter's L1 norm: 2e-6 * max(1, L1) is ~16 such roundings
        // amplified by the whole L1 norm, far above what float gives and far
        // below any structural error (a wrong sign or delay is >= 1e-3).
        EXPECT_LE(worst, 2e-6 * std::max(1.0, l1)) << c["name"];
        std::printf("%-24s float impulse response: worst error %.2e (tolerance %.2e)\n",
                    c["name"].get<std::string>().c_str(), worst, 2e-6 * std::max(1.0, l1));
    }
}

TEST(BiquadFloat, FrequencyResponseFromImpulseDftMatchesScipySosfreqz) {
    for (const auto& c : golden()["filters"]) {
        const auto sos = sos_from(c["sos"]);
        BiquadCascade<float, 4> f;
        ASSERT_TRUE(f.configure(sos.data(), static_cast<int>(sos.size()), {}, {}).ok());
        // 20000 samples: the slowest poles (|z| ~ 0.956) have decayed to 1e-300.
        std::vector<double> h(20000);
        for (size_t n = 0; n < h.size(); ++n) h[n] = f.apply(n == 0 ? 1.0f : 0.0f);
        const auto freqs = vec(c["freqs_Hz"]);
        const auto re = vec(c["h_re"]);
        const auto im = vec(c["h_im"]);
        const double l1 = c["impulse_l1"].get<double>();
        for (size_t k = 0; k < freqs.size(); ++k) {
            const double w = kTwoPi * freqs[k] / golden()["fs"].get<double>();
            std::complex<double> H = 0.0;
            for (size_t n = 0; n < h.size(); ++n) H += h[n] * std::polar(1.0, -w * static_cast<double>(n));
            // The DFT error is bounded by the sum of the impulse-response
            // errors: the per-sample float error of the previous test
            // (<= 2e-6 L1) decays with the filter's own poles, so its sum is
            // within another factor L1; 1e-5 * max(1, L1)^2 bounds that.
            const double tol = 1e-5 * std::max(1.0, l1) * std::max(1.0, l1);
            EXPECT_LE(std::abs(H - std::complex<double>(re[k], im[k])), tol)
                << c["name"] << " at " << freqs[k] << " Hz";
        }
    }
}

// ---------------------------------------------------------------------------
// Q31 cascade, well-conditioned filters

TEST(BiquadQ31, ImpulseResponseMatchesScipySosfilt) {
    // Impulse of 1/16 full scale: every node of every filter stays below
    // full scale (the largest L1 norm is 12.9, the resonance).
    const int32_t amp_raw = 1 << 27;
    const double amp = amp_raw * kLsb;
    for (const auto& c : golden()["filters"]) {
        const auto sos = sos_from(c["sos"]);
        BiquadCascade<Q31, 4> q;
        ASSERT_TRUE(q.configure(sos.data(), static_cast<int>(sos.size()), {}, {}).ok());
        const auto h = vec(c["impulse"]);
        double worst_lsb = 0.0;
        for (size_t n = 0; n < h.size(); ++n) {
            const int32_t y = q.apply(Q31::from_raw(n == 0 ? amp_raw : 0)).raw();
            worst_lsb = std::max(worst_lsb, std::fabs(y - amp * h[n] / kLsb));
        }
        // Coefficients are quantised to 2^(e-32) with e <= 2 (a relative
        // 2^-30 of the section's coefficient sum); the response error that
        // causes is at most ~L1(h)^2 * 2^-30 * amp, i.e. < 11 LSB for the
        // lightly damped resonance (L1 = 12.9). Output rounding adds a shaped
        // residual of a few LSB. 32 LSB (1.5e-8 of full scale) covers both.
        EXPECT_LE(worst_lsb, 32.0) << c["name"];
        std::printf("%-24s Q31 impulse response: worst error %.1f LSB (tolerance 32)\n",
                    c["name"].get<std::string>().c_str(), worst_lsb);
    }
}

namespace {

// Plain direct form I in double, the same difference equation as scipy's
// sosfilt: the reference for inputs too long to store in the golden file.
struct DoubleCascade {
    std::vector<SosSection> sos;
    std::vector<std::array<double, 4>> z;  // x1 x2 y1 y2 per section
    explicit DoubleCascade(std::vector<SosSection> s) : sos(std::move(s)), z(sos.size()) {}
    double apply(double x) {
        for (size_t i = 0; i < sos.size(); ++i) {
            const SosSection& c = sos[i];
            auto& h = z[i];
            const double y = c.b0 * x + c.b1 * h[0] + c.b2 * h[1] - c.a1 * h[2] - c.a2 * h[3];
            h = {x, h[0], y, h[2]};
            x = y;
        }
        return x;
    }
};

// ||1/A||_2 of one section: the RMS gain from a rounding error injected into
// its recursion to its output.
double feedback_l2(const SosSection& s) {
    double y1 = 0.0, y2 = 0.0, sum = 0.0;
    for (int n = 0; n < 200000; ++n) {
        const double y = (n == 0 ? 1.0 : 0.0) - s.a1 * y1 - s.a2 * y2;
        sum += y * y;
        y2 = y1;
        y1 = y;
    }
    return std::sqrt(sum);
}

}  // namespace

TEST(BiquadQ31, AgreesWithFloatCascadeOnRandomInput) {
    std::mt19937 rng(20240611);
    for (const auto& c : golden()["filters"]) {
        const auto sos = sos_from(c["sos"]);
        const double l1 = c["impulse_l1"].get<double>();
        BiquadCascade<Q31, 4> q;
        BiquadCascade<float, 4> f;
        DoubleCascade d(sos);
        ASSERT_TRUE(q.configure(sos.data(), static_cast<int>(sos.size()), {}, {}).ok());
        ASSERT_TRUE(f.configure(sos.data(), static_cast<int>(sos.size()), {}, {}).ok());
        // |x| <= 0.9 / L1 keeps every output below 0.9 full scale.
        std::uniform_real_distribution<double> u(-0.9 / std::max(1.0, l1), 0.9 / std::max(1.0, l1));
        double q_vs_d = 0.0, f_vs_d = 0.0, q_vs_f = 0.0, y_max = 0.0;
        for (int n = 0; n < 20000; ++n) {
            const Q31 x = Q31::from_double(u(rng));
            const double yq = q.apply(x).raw() * kLsb;
            const double yf = f.apply(x.to_float());
            const double yd = d.apply(x.to_double());
            q_vs_d = std::max(q_vs_d, std::fabs(yq - yd));
            f_vs_d = std::max(f_vs_d, std::fabs(yf - yd));
            q_vs_f = std::max(q_vs_f, std::fabs(yq - yf));
            y_max = std::max(y_max, std::fabs(yd));
        }
        // Q31: same budget as the impulse test, 32 LSB.
        const double q_tol = 32 * kLsb;
        // float DF2T: ~9 roundings per section of up to 2^-24 relative (RMS
        // 2^-24 / sqrt(3) each) on values up to ~3 |y|max, each reaching the
        // output through 1/A(z). An upper estimate of the RMS error is
        // 2^-24 * 3 |y|max * sqrt(9/3) * sum_k ||1/A_k||_2 (actual values are
        // mostly far below 3 |y|max); the peak of 20000 noise samples stays
        // within 6 times that. Coefficient rounding (2^-24 relative) gives a
        // response error of the same order, covered by the same factor.
        double l2 = 0.0;
        for (const auto& s : sos) l2 += feedback_l2(s);
        const double f_tol = 6.0 * std::ldexp(1.0, -24) * 3.0 * y_max * std::sqrt(3.0) * l2;
        EXPECT_LE(q_vs_d, q_tol) << c["name"];
        EXPECT_LE(f_vs_d, f_tol) << c["name"];
        // Hence the stated Q31-vs-float bound.
        EXPECT_LE(q_vs_f, q_tol + f_tol) << c["name"];
        std::printf("%-24s noise: Q31-double %.1f LSB (tol 32), float-double %.0f LSB (tol %.0f), "
                    "Q31-float %.0f LSB (tol %.0f)\n",
                    c["name"].get<std::string>().c_str(), q_vs_d / kLsb, f_vs_d / kLsb, f_tol / kLsb,
                    q_vs_f / kLsb, (q_tol + f_tol) / kLsb);
    }
}

TEST(BiquadQ31, SaturatesInsteadOfWrapping) {
    // Gain-4 section: 0.5 full scale in gives +-1 out, which must clamp.
    const SosSection gain4{4.0, 0.0, 0.0, 0.0, 0.0};
    BiquadCascade<Q31, 1> q;
    ASSERT_TRUE(q.configure(&gain4, 1, {}, {}).ok());
    EXPECT_EQ(q.apply(Q31::from_double(0.5)).raw(), Q31::kMaxRaw);
    EXPECT_EQ(q.apply(Q31::from_double(-0.5)).raw(), Q31::kMinRaw);
    EXPECT_EQ(q.apply(Q31::from_double(0.125)).raw(), Q31::from_double(0.5).raw());

    // Low-pass with DC gain 2 driven to saturation and back: the output never
    // changes sign while the input is positive and recovers afterwards.
    const SosSection lp{0.1, 0.1, 0.0, -0.9, 0.0};  // (0.1 + 0.1 z^-1) / (1 - 0.9 z^-1)
    ASSERT_TRUE(q.configure(&lp, 1, {}, {}).ok());
    q.reset();
    for (int n = 0; n < 500; ++n) EXPECT_GT(q.apply(Q31::from_double(0.9)).raw(), 0);
    EXPECT_EQ(q.apply(Q31::from_double(0.9)).raw(), Q31::kMaxRaw);
    int32_t y = 0;
    for (int n = 0; n < 500; ++n) y = q.apply(Q31::from_double(0.25)).raw();
    // Settles to 2 * 0.25 = 0.5 within a few LSB.
    EXPECT_NEAR(y, Q31::from_double(0.5).raw(), 4);
}

TEST(BiquadQ31, HighGainNumeratorMatchesDoubleRecursion) {
    // A lag-lead section with a numerator far above the plain range (sum|b|
    // ~ 440 > 8, shifted left in the kernel): 220 (1 - 0.9997 z^-1)(1 + z^-1)
    // over a pole pair at 0.999 +- 0.01j, the shape of Ahmad2020 K(s)'s last
    // section at 10 kHz (DC gain ~1300).
    //
    // The coefficients are rounded to what the Q31 formats hold exactly
    // (numerator mantissas of exponent 9: steps of 2^-22; a1 + 2 and a2 - 1
    // with exponent -8: steps of 2^-39), so the reference, the same
    // difference equation in double, tests the arithmetic (left shift, error
    // feedback, histories) and not the coefficient quantisation.
    auto grid = [](double v, double step) { return std::nearbyint(v / step) * step; };
    const double b_step = std::ldexp(1.0, -22), c_step = std::ldexp(1.0, -39);
    const double z0 = 0.9997, pr = 0.999, pim = 0.01;
    const double c1 = grid(2.0 - 2.0 * pr, c_step), c2 = grid(pr * pr + pim * pim - 1.0, c_step);
    const SosSection s{220.0, grid(220.0 * (1.0 - z0), b_step), grid(-220.0 * z0, b_step), c1 - 2.0, c2 + 1.0};
    BiquadCascade<Q31, 1> q;
    ASSERT_TRUE(q.configure(&s, 1, {}, {}).ok());
    std::mt19937 rng(7);
    std::uniform_real_distribution<double> u(-1.0, 1.0);
    double x1 = 0, x2 = 0, y1 = 0, y2 = 0, worst = 0.0, peak = 0.0;
    for (int n = 0; n < 20000; ++n) {
        // A slow sine plus noise, ~2e-5 of full scale: the low-frequency gain
        // keeps the output below 0.5 of full scale.
        const Q31 xq = Q31::from_double(2e-5 * std::sin(0.002 * n) + 2e-6 * u(rng));
        const double x = xq.to_double();
        const double y = s.b0 * x + s.b1 * x1 + s.b2 * x2 - s.a1 * y1 - s.a2 * y2;
        x2 = x1; x1 = x; y2 = y1; y1 = y;
        const double yq = q.apply(xq).to_double();
        worst = std::max(worst, std::fabs(yq - y));
        peak = std::max(peak, std::fabs(y));
    }
    ASSERT_LT(peak, 0.5);
    ASSERT_GT(peak, 0.01);  // the test exercises the gain, not just rounding
    // What remains is rounding: the output's floor, shaped by the error
    // feedback's double zero at z = 1 (|1 - z^-1|^2 <= 4: at most 4 LSB), and
    // the floors of the shifted feedback products (2^-59 of full scale each,
    // ~1e-15 after the DC gain). 8 LSB bounds it; a wrong shift or a lost
    // residual is off by orders of magnitude more.
    EXPECT_LT(worst, 8 * kLsb) << "worst error " << worst;
    std::printf("high-gain Q31 section: peak output %.3g, worst error %.3g (%.1f LSB)\n", peak, worst,
                worst / kLsb);
}

TEST(BiquadQ31, HighGainNumeratorSaturatesWithTheSignOfTheExactResult) {
    // Gain 1000: a numerator of more than 8 full scales is clamped inside
    // the kernel; the output must still saturate on the side of the exact
    // value, for inputs just past 1/1000 of full scale up to full scale, and
    // recover as soon as the input is small again.
    const SosSection g{1000.0, 0.0, 0.0, 0.0, 0.0};
    BiquadCascade<Q31, 1> q;
    ASSERT_TRUE(q.configure(&g, 1, {}, {}).ok());
    for (double x : {0.0011, 0.01, 0.5, 0.999}) {
        EXPECT_EQ(q.apply(Q31::from_double(x)).raw(), Q31::kMaxRaw) << x;
        EXPECT_EQ(q.apply(Q31::from_double(-x)).raw(), Q31::kMinRaw) << x;
    }
    EXPECT_EQ(q.apply(Q31::from_raw(Q31::kMinRaw)).raw(), Q31::kMinRaw);
    // Exact below the clamp: 1000 * 2^-20 = 0.00095367431640625.
    EXPECT_EQ(q.apply(Q31::from_raw(1 << 11)).to_double(), 1000.0 * 2048.0 * kLsb);
    EXPECT_EQ(q.apply(Q31::from_raw(-(1 << 11))).to_double(), -1000.0 * 2048.0 * kLsb);
}

TEST(BiquadQ31, InputAndOutputScalesAreFoldedIntoTheGain) {
    // Physical gain 3 V/V from a 1 V input scale to a 6 V output scale is
    // 0.5 between samples.
    const SosSection gain3{3.0, 0.0, 0.0, 0.0, 0.0};
    BiquadCascade<Q31, 1> q;
    ASSERT_TRUE(q.configure(&gain3, 1, SignalScale{1.0f}, SignalScale{6.0f}).ok());
    EXPECT_EQ(q.apply(Q31::from_double(0.5)).raw(), Q31::from_double(0.25).raw());
    // float ignores the scales: the sample is the physical value.
    BiquadCascade<float, 1> f;
    ASSERT_TRUE(f.configure(&gain3, 1, SignalScale{1.0f}, SignalScale{6.0f}).ok());
    EXPECT_EQ(f.apply(0.5f), 1.5f);
}

// ---------------------------------------------------------------------------
// Ahmad2020 K(s) at 100 kHz: the reason the Q31 structure exists.

namespace {

struct AhmadSetup {
    std::vector<SosSection> sos;
    // Input: error voltage with 0.01 V full scale; output: control voltage
    // with 10 V full scale. DC gain 607 -> 0.607 between samples, and the
    // largest partial cascade (L1 22.7 and 26.9 times the 1e-3 scale folded
    // into section 0, then 624 times 1e-3 at the output) stays < 1.
    SignalScale in{0.01f}, out{10.0f};
};

AhmadSetup ahmad() {
    AhmadSetup s;
    s.sos = sos_from(golden()["ahmad2020_k"]["sos"]);
    return s;
}

}  // namespace

TEST(BiquadAhmad2020, Q31StepResponseMatchesFloat64Design) {
    const auto k = golden()["ahmad2020_k"];
    const AhmadSetup s = ahmad();
    BiquadCascade<Q31, 3> q;
    ASSERT_TRUE(q.configure(s.sos.data(), 3, s.in, s.out).ok());
    const Q31 x = Q31::from_double(0.9);  // 9 mV step
    const double x_V = x.to_double() * s.in.full_scale;
    const auto idx = k["step_index"].get<std::vector<int>>();
    const auto ref = vec(k["step"]);
    const double final_V = x_V * ref.back();
    size_t j = 0;
    double worst_rel = 0.0;
    for (int n = 0; j < idx.size(); ++n) {
        const double y_V = q.apply(x).to_double() * s.out.full_scale;
        if (n == idx[j]) {
            const double want = x_V * ref[j];
            // Coefficient quantisation sets the error: in the slow section
            // 1 + a1 + a2 = 1.06e-9 is resolved to 2^-44 (half LSB of
            // exponent -12), relative 5.4e-5; its numerator sum 6.3e-5 to
            // 2^-31, relative 7e-6; the other sections are ~1e-6 or better.
            // So the DC gain is within ~6.2e-5: 2e-4 of the final value is a
            // 3x margin, plus 64 LSB for the output rounding and the
            // unshaped product truncation (~4 LSB after the 1e9 DC gain).
            const double tol = 2e-4 * std::fabs(final_V) + 64 * kLsb * s.out.full_scale;
            EXPECT_NEAR(y_V, want, tol) << "sample " << n;
            worst_rel = std::max(worst_rel, std::fabs(y_V - want) / std::fabs(final_V));
            ++j;
        }
    }
    std::printf("Ahmad2020 K(s), Q31 step response: worst error %.3g of the final value\n", worst_rel);
}

TEST(BiquadAhmad2020, Q31AndFloatSinusoidalGainsMatchDesign) {
    const auto k = golden()["ahmad2020_k"];
    const AhmadSetup s = ahmad();
    const double fs = k["fs"].get<double>();
    const auto freqs = vec(k["freqs_Hz"]);
    const auto re = vec(k["h_re"]);
    const auto im = vec(k["h_im"]);
    // 4 s of settling: the slowest mode decays as e^{-3.19 t}, to 3e-6 of its
    // initial size; then a 1 s window (a whole number of periods for every
    // test frequency, including 2 periods per 5 samples at 40 kHz).
    const int settle = 400000, window = 100000;
    for (size_t i = 0; i < freqs.size(); ++i) {
        const std::complex<double> want(re[i], im[i]);
        BiquadCascade<Q31, 3> q;
        ASSERT_TRUE(q.configure(s.sos.data(), 3, s.in, s.out).ok());
        const auto hq = measure_gain(
            [&](double x_V) {
                return q.apply(Q31::from_double(x_V / s.in.full_scale)).to_double() * s.out.full_scale;
            },
            freqs[i], fs, 0.5 * s.in.full_scale, settle, window);
        BiquadCascade<float, 3> f;
        ASSERT_TRUE(f.configure(s.sos.data(), 3, s.in, s.out).ok());
        const auto hf = measure_gain([&](double x_V) { return static_cast<double>(f.apply(static_cast<float>(x_V))); },
                                     freqs[i], fs, 0.5 * s.in.full_scale, settle, window);
        const double eq = std::abs(hq - want) / std::abs(want);
        const double ef = std::abs(hf - want) / std::abs(want);
        std::printf("Ahmad2020 K at %7.0f Hz: |H| design %.6g, Q31 rel. error %.2e, float rel. error %.2e\n",
                    freqs[i], std::abs(want), eq, ef);
        // Same budget as the step response: <= 6.2e-5 from coefficient
        // quantisation (largest at low frequency, where the slow section
        // dominates), 3e-6 of transient left after 4 s, ~1e-9 from output
        // rounding: 2e-4 relative (magnitude and phase together).
        EXPECT_LE(eq, 2e-4) << freqs[i] << " Hz";
        // Float: coefficients to 2^-24 relative (c0 = 1 + a1 + a2 included,
        // being computed in double before rounding), but the cascade's first
        // two sections cancel at low frequency (the L1 norm of their impulse
        // response is ~2600 times their DC gain), so their 2^-24 roundings
        // reach the output as ~2600 * 2^-24 * a few ~ 5e-4; the same
        // transient and window budget as Q31 on top: 1e-3.
        EXPECT_LE(ef, 1e-3) << freqs[i] << " Hz";
    }
}

// ---------------------------------------------------------------------------
// configure: validation, error naming, nothing changes on rejection

namespace {

template <class T>
double to_d(T v) {
    if constexpr (std::is_same_v<T, float>) return v; else return v.to_double();
}
template <class T>
T from_d(double v) {
    if constexpr (std::is_same_v<T, float>) return static_cast<float>(v); else return Q31::from_double(v);
}

template <class T>
void check_rejections_keep_configuration_and_state() {
    const SosSection good[3] = {{0.2, 0.3, 0.1, -0.5, 0.1}, {0.5, 0.0, -0.2, 0.4, 0.3}, {0.3, 0.2, 0.05, -1.2, 0.5}};
    BiquadCascade<T, 3> a, ref;
    ASSERT_TRUE(a.configure(good, 3, {}, {}).ok());
    ASSERT_TRUE(ref.configure(good, 3, {}, {}).ok());
    std::mt19937 rng(7);
    std::uniform_real_distribution<double> u(-0.3, 0.3);
    std::vector<double> xs(400);
    for (auto& v : xs) v = u(rng);
    for (int n = 0; n < 200; ++n) {
        a.apply(from_d<T>(xs[static_cast<size_t>(n)]));
        ref.apply(from_d<T>(xs[static_cast<size_t>(n)]));
    }

    struct Bad {
        int section, coef;  // coef: 0..4 = b0 b1 b2 a1 a2
        double value;
        const char* field;
    };
    const double nan = std::nan(""), inf = HUGE_VAL;
    const Bad bads[] = {
        {1, 1, nan, "sections[1].b1"},  {2, 0, inf, "sections[2].b0"},  {0, 4, -inf, "sections[0].a2"},
        {2, 4, 1.0, "sections[2].a2"},  {2, 4, -1.0, "sections[2].a2"}, {1, 3, 1.3, "sections[1].a1"},
        {0, 3, -1.1, "sections[0].a1"}, {2, 3, 2.5, "sections[2].a1"},
    };
    for (const Bad& b : bads) {
        SosSection s[3] = {good[0], good[1], good[2]};
        double* c[5] = {&s[b.section].b0, &s[b.section].b1, &s[b.section].b2, &s[b.section].a1, &s[b.section].a2};
        *c[b.coef] = b.value;
        const Status st = a.configure(s, 3, {}, {});
        ASSERT_FALSE(st.ok()) << b.field;
        EXPECT_STREQ(st.field, b.field);
        ASSERT_NE(st.message, nullptr);
    }
    {
        Status st = a.configure(good, 0, {}, {});
        EXPECT_STREQ(st.field, "count");
        st = a.configure(good, 4, {}, {});
        EXPECT_STREQ(st.field, "count");
        st = a.configure(nullptr, 1, {}, {});
        EXPECT_STREQ(st.field, "sections");
        st = a.configure(good, 3, SignalScale{0.0f}, {});
        EXPECT_STREQ(st.field, "in.full_scale");
        st = a.configure(good, 3, {}, SignalScale{-1.0f});
        EXPECT_STREQ(st.field, "out.full_scale");
        st = a.configure(good, 3, {}, SignalScale{std::nanf("")});
        EXPECT_STREQ(st.field, "out.full_scale");
    }
    EXPECT_EQ(a.count(), 3);
    // Every rejection left coefficients and state as they were: the output
    // continues bit for bit like the untouched reference.
    for (int n = 200; n < 400; ++n) {
        const T ya = a.apply(from_d<T>(xs[static_cast<size_t>(n)]));
        const T yr = ref.apply(from_d<T>(xs[static_cast<size_t>(n)]));
        ASSERT_EQ(ya, yr) << "sample " << n;
    }
    // A 3-section cascade of these sections is far from pass-through, so the
    // comparison above was not vacuous.
    EXPECT_NE(to_d<T>(a.apply(from_d<T>(0.25))), 0.25);
}

}  // namespace

TEST(BiquadConfigure, FloatRejectsNamingTheFieldAndKeepsConfigurationAndState) {
    check_rejections_keep_configuration_and_state<float>();
}

TEST(BiquadConfigure, Q31RejectsNamingTheFieldAndKeepsConfigurationAndState) {
    check_rejections_keep_configuration_and_state<Q31>();
}

TEST(BiquadConfigure, RealisationSpecificLimits) {
    // Valid in double, but float rounds a2 = 1 - 1e-9 to 1: refused by the
    // float cascade, fine for Q31 (c2 = a2 - 1 keeps it).
    const SosSection near_circle{1e-3, 0.0, 0.0, 0.0, 1.0 - 1e-9};
    BiquadCascade<float, 1> f;
    Status st = f.configure(&near_circle, 1, {}, {});
    ASSERT_FALSE(st.ok());
    EXPECT_STREQ(st.field, "sections[0].a2");
    EXPECT_EQ(f.count(), 0);
    EXPECT_EQ(f.apply(0.5f), 0.5f);  // unconfigured: pass-through
    BiquadCascade<Q31, 1> q;
    EXPECT_TRUE(q.configure(&near_circle, 1, {}, {}).ok());
    // ... but 1 - 1e-10 is below the Q31 resolution of c2 (2^-29 here).
    const SosSection too_close{1e-3, 0.0, 0.0, 0.0, 1.0 - 1e-10};
    st = q.configure(&too_close, 1, {}, {});
    ASSERT_FALSE(st.ok());
    EXPECT_STREQ(st.field, "sections[0].a2");
    // Q31 numerators are limited to sum|b| < 2^24 in sample units, including
    // the folded scale: 0.1 V/V from a 1e9 V input scale to 1 V is 1e8.
    const SosSection small{0.1, 0.0, 0.0, 0.0, 0.0};
    st = q.configure(&small, 1, SignalScale{1e9f}, SignalScale{1.0f});
    ASSERT_FALSE(st.ok());
    EXPECT_STREQ(st.field, "sections[0].b0");
    EXPECT_TRUE(q.configure(&small, 1, SignalScale{1e8f}, SignalScale{1.0f}).ok());  // 1e7
    // Field names are built for every section index up to MaxSections.
    SosSection many[12];
    for (auto& s : many) s = SosSection{1.0, 0.0, 0.0, 0.0, 0.5};
    many[11].a2 = 1.5;
    BiquadCascade<float, 12> big;
    st = big.configure(many, 12, {}, {});
    EXPECT_STREQ(st.field, "sections[11].a2");
}

TEST(BiquadConfigure, RetuningKeepsStateUnlessTheSectionCountChanges) {
    const SosSection lp{0.1, 0.1, 0.0, -0.8, 0.0};
    const SosSection lp2[2] = {lp, lp};
    BiquadCascade<Q31, 2> q;
    ASSERT_TRUE(q.configure(&lp, 1, {}, {}).ok());
    for (int n = 0; n < 200; ++n) q.apply(Q31::from_double(0.5));
    // Same count: the history carries on, the output continues at DC gain 1.
    ASSERT_TRUE(q.configure(&lp, 1, {}, {}).ok());
    EXPECT_NEAR(q.apply(Q31::from_double(0.5)).to_double(), 0.5, 1e-8);
    // New count: state is zeroed, the first output is b0 * x.
    ASSERT_TRUE(q.configure(lp2, 2, {}, {}).ok());
    EXPECT_NEAR(q.apply(Q31::from_double(0.5)).to_double(), 0.1 * 0.1 * 0.5, 1e-8);
    q.reset();
    EXPECT_NEAR(q.apply(Q31::from_double(0.5)).to_double(), 0.1 * 0.1 * 0.5, 1e-8);
}

// ---------------------------------------------------------------------------
// settle(x): the DC steady state of a constant input, against scipy's
// sosfilt_zi (tools/ref/biquad_settle_ref.py -> tests/golden/biquad_settle_ref.json).

namespace {

const nlohmann::json& settle_golden() {
    static const nlohmann::json j = [] {
        std::ifstream f(std::string(PIEZOLOOP_GOLDEN_DIR) + "/biquad_settle_ref.json");
        return nlohmann::json::parse(f);
    }();
    return j;
}

const nlohmann::json& settle_case(const std::string& name) {
    for (const auto& c : settle_golden()["cases"])
        if (c["name"] == name) return c;
    throw std::runtime_error("no settle case " + name);
}

// The float cascade settled on x: its states against sosfilt_zi (x times
// the unit-input states), then x in for `ticks` samples: every output H(1) x.
// DF2T: s1, s2 as scipy's transposed direct form II states. Delta form:
// s1 is the same quantity (y - b0 x of the section), s2 = c1 s1 - g1 x_in
// (its increment d s1 = -c1 s1 + s2 + g1 x_in zero), residuals zero.
// Tolerance: the states come from the float-rounded coefficients (2^-24
// relative) through the section's DC gain 1 / c0 (DF2T: <= 16; delta form:
// c0 kept to 2^-24 of itself), and from float products of ~|x|: 2e-6 of
// |x| (1 + |state / x|) covers both (measured: 5e-8). The outputs then,
// for as long as x stays: within 2e-6 of |x| of scipy's H(1) x (measured
// 8e-7: the float coefficients' own DC gain).
void expect_float_settles(const std::string& name, SectionForm form, int ticks) {
    const nlohmann::json& c = settle_case(name);
    const std::vector<SosSection> sos = sos_from(c["sos"]);
    const std::vector<double> gain = vec(c["node_gain"]);
    const int n = static_cast<int>(sos.size());
    for (const double x : {7.25, -31.5, 0.004}) {
        BiquadCascade<float, 4> f;
        ASSERT_TRUE(f.configure(sos.data(), n, SignalScale{1.0f}, SignalScale{1.0f}).ok());
        for (int k = 0; k < 50; ++k) (void)f.apply(-3.0f);  // somewhere else first
        f.settle(static_cast<float>(x));
        BiquadCascade<float, 4>::Snapshot st{};
        f.save(st);
        for (int i = 0; i < n; ++i) {
            ASSERT_EQ(f.form(i), form) << name << " section " << i;
            const SosSection& s = sos[static_cast<std::size_t>(i)];
            const double in = i == 0 ? x : x * gain[static_cast<std::size_t>(i) - 1];
            const double z1 = c["zi"][i][0].get<double>() * x;
            double z2 = c["zi"][i][1].get<double>() * x;
            if (form == SectionForm::kDelta) {
                const double c1 = s.a1 + 2.0;
                const double g1 = (2.0 * s.b0 + s.b1) - s.b0 * c1;
                z2 = c1 * z1 - g1 * in;
                EXPECT_EQ(st[static_cast<std::size_t>(i)].r1, 0.0f);
                EXPECT_EQ(st[static_cast<std::size_t>(i)].r2, 0.0f);
            }
            const double tol1 = 2e-6 * std::fabs(x) * (1.0 + std::fabs(z1 / x));
            const double tol2 = 2e-6 * std::fabs(x) * (1.0 + std::fabs(z2 / x));
            EXPECT_NEAR(st[static_cast<std::size_t>(i)].s1, z1, tol1) << name << " x " << x << " section " << i;
            EXPECT_NEAR(st[static_cast<std::size_t>(i)].s2, z2, tol2) << name << " x " << x << " section " << i;
        }
        const double steady = c["steady"].get<double>() * x;
        double worst = 0.0;
        for (int k = 0; k < ticks; ++k)
            worst = std::max(worst, std::fabs(f.apply(static_cast<float>(x)) - steady));
        EXPECT_LE(worst, 2e-6 * std::fabs(x)) << name << " x " << x << ": settled output H(1) x from the first sample";
    }
}

// The Q31 cascade settled on x (in = out full scale): the histories of
// every node at x times the DC gain up to it, the unrounded accumulators at
// the same value in Q59, then x in for `ticks` samples: every output within
// 3 LSB of the settled one (the section's own rounding limit cycle, measured
// 2 LSB; no transient), and the nodes within 4e-6 of |x| + 4 LSB of scipy's
// DC gains: the quantised coefficients have their own DC gain (the 100 kHz
// cascade's 1 + a1 + a2 ~ 4e-5 and its numerator sums at a 2^-31 block
// resolution; measured 1.7e-6 of |x| there, within 2 LSB at 10 kHz).
void expect_q31_settles(const std::string& name, int ticks) {
    const nlohmann::json& c = settle_case(name);
    const std::vector<SosSection> sos = sos_from(c["sos"]);
    const std::vector<double> gain = vec(c["node_gain"]);
    const int n = static_cast<int>(sos.size());
    for (const double x : {0.3, -0.45, 1e-4}) {
        BiquadCascade<Q31, 4> q;
        ASSERT_TRUE(q.configure(sos.data(), n, SignalScale{1.0f}, SignalScale{1.0f}).ok());
        for (int k = 0; k < 50; ++k) (void)q.apply(Q31::from_double(-0.2));
        const Q31 in = Q31::from_double(x);
        q.settle(in);
        BiquadCascade<Q31, 4>::Snapshot st{};
        q.save(st);
        const double rel = 4e-6 * std::fabs(x);
        EXPECT_EQ(st.hist[0][0], in.raw());
        EXPECT_EQ(st.hist[0][1], in.raw());
        for (int i = 0; i < n; ++i) {
            const double node = x * gain[static_cast<std::size_t>(i)];
            const auto& h = st.hist[static_cast<std::size_t>(i) + 1];
            const auto& w = st.wide[static_cast<std::size_t>(i)];
            EXPECT_EQ(h[0], h[1]);
            EXPECT_EQ(w[0], w[1]);
            EXPECT_EQ(w[0] >> 28, h[0]) << "the accumulator rounds to the history";
            EXPECT_NEAR(h[0] * kLsb, node, rel + 4 * kLsb) << name << " x " << x << " node " << i;
            EXPECT_NEAR(static_cast<double>(w[0]) * kLsb / 268435456.0, node, rel + 4 * kLsb) << name << " node " << i;
        }
        const int32_t settled = st.hist[static_cast<std::size_t>(n)][0];
        EXPECT_NEAR(settled * kLsb, c["steady"].get<double>() * x, rel + 4 * kLsb) << name << " x " << x;
        int64_t worst = 0;
        for (int k = 0; k < ticks; ++k) {
            const int64_t d = int64_t{q.apply(in).raw()} - settled;
            worst = std::max(worst, d < 0 ? -d : d);
        }
        EXPECT_LE(worst, 3) << name << " x " << x << ": LSB from the settled output";
    }
}

}  // namespace

TEST(BiquadSettle, FloatDf2tStatesAreScipysSteadyState) {
    expect_float_settles("notch_lowpass_10k", SectionForm::kDf2t, 2000);
    expect_float_settles("gain_0p8_10k", SectionForm::kDf2t, 2000);
}

TEST(BiquadSettle, FloatDeltaFormStatesAreTheSteadyState) {
    expect_float_settles("lowpass_near_z1_100k", SectionForm::kDelta, 20000);
    expect_float_settles("highpass_10k", SectionForm::kDelta, 20000);  // DC gain 0
}

TEST(BiquadSettle, Q31HistoriesAndAccumulatorsAreTheSteadyState) {
    for (const char* name : {"notch_lowpass_10k", "lowpass_near_z1_100k", "highpass_10k", "gain_0p8_10k"})
        expect_q31_settles(name, 20000);
}

TEST(BiquadSettle, WithoutItTheFilterStepsFromWhereItWas) {
    // What settle() prevents: a filter holding 0 fed x steps through its
    // step response (its first output the product of the b0s times x,
    // 14 % of the way).
    const nlohmann::json& c = settle_case("notch_lowpass_10k");
    const std::vector<SosSection> sos = sos_from(c["sos"]);
    BiquadCascade<float, 2> f;
    ASSERT_TRUE(f.configure(sos.data(), 2, SignalScale{1.0f}, SignalScale{1.0f}).ok());
    EXPECT_LT(f.apply(10.0f), 2.0f);
    f.settle(10.0f);
    EXPECT_NEAR(f.apply(10.0f), 10.0f, 1e-4f);
}

TEST(BiquadSettle, ZeroIsResetExactly) {
    const nlohmann::json& c = settle_case("lowpass_near_z1_100k");
    const std::vector<SosSection> sos = sos_from(c["sos"]);
    BiquadCascade<float, 2> f, rest;
    BiquadCascade<Q31, 2> q, qrest;
    ASSERT_TRUE(f.configure(sos.data(), 2, SignalScale{1.0f}, SignalScale{1.0f}).ok());
    ASSERT_TRUE(rest.configure(sos.data(), 2, SignalScale{1.0f}, SignalScale{1.0f}).ok());
    ASSERT_TRUE(q.configure(sos.data(), 2, SignalScale{1.0f}, SignalScale{1.0f}).ok());
    ASSERT_TRUE(qrest.configure(sos.data(), 2, SignalScale{1.0f}, SignalScale{1.0f}).ok());
    for (int k = 0; k < 100; ++k) {
        (void)f.apply(-2.5f);
        (void)q.apply(Q31::from_double(0.1));
    }
    f.settle(0.0f);
    q.settle(Q31{});
    for (int k = 0; k < 100; ++k) {
        const float x = static_cast<float>(std::sin(0.01 * k));
        const float a = f.apply(x), b = rest.apply(x);
        ASSERT_EQ(std::memcmp(&a, &b, sizeof a), 0) << k;  // bit for bit, sign of zero included
        ASSERT_EQ(q.apply(Q31::from_double(0.5 * x)).raw(), qrest.apply(Q31::from_double(0.5 * x)).raw()) << k;
    }
}
