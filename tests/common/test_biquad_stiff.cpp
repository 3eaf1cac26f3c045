// The float cascade (common/piezoloop/biquad.hpp: DF2T where float32 holds a
// section, delta-operator sections with compensated states elsewhere) on
// stiff sections, against scipy in double
// (tools/ref/stiff_sections_ref.py -> tests/golden/stiff_sections_ref.json):
// Ahmad2020 K(s), Janaideh2016 C(s), a PI-lead with its pole at 0.02 Hz and a
// 50 Hz notch, each at 10, 20, 50 and 100 kHz.
//
// Tolerances come from float32 rounding (u = 2^-24, round to nearest), not
// from what the cascade was seen to do:
//  * coefficients, delta sections: configure() rounds b0, g1, g0, c1, c0
//    (computed in double) to float once, relative error <= u each. To first
//    order the section's response moves by at most u * sens(w), with
//      sens = |b0| + (|g1||d| + |g0|) / |D| + |G| (|c1||d| + |c0|) / |D|^2,
//    d = e^{jw} - 1, D = d^2 + c1 d + c0, G = g1 d + g0
//    (the sum of |dH / dc| |c| over the five coefficients), i.e. relative
//    u * kappa with kappa = sens / |H_section|.
//    DF2T sections: configure() chose DF2T because float rounding moves
//    c1, c0, n1, n0 (N = b0 d^2 + n1 d + n0) by at most t = 2^-16 of
//    themselves (and b0 by u), so relative t * kappa with
//      kappa = (|n1||d| + |n0|) / |N| + (|c1||d| + |c0|) / |D|.
//    A cascade adds the sections' terms. Allowed: twice the sum (second-
//    order terms and the double arithmetic that makes the coefficients).
//  * arithmetic: 17 float operations per section and sample, each rounding
//    <= u of its result; a result is at most ~4 times the larger of the
//    section's input and output (|c1| < 4, the states are partial outputs),
//    and the compensated states put each rounding back through a gain of
//    ~1 to the section's output instead of 1 / c0. An error made in section
//    i then passes the sections after it. Summed over the record:
//      sum_n |h_float[n] - h[n]| <= 64 u sum_i N_i A_i,
//    N_i = L1 norm of the impulse response at section i's input or output
//    (the larger), A_i = L1 norm of the sections after i (1 for the last);
//    17 * 4 rounded down to 64 as the roundings do not all reach their
//    bound together. This bounds each impulse sample and the DFT error. It
//    matters for cascades whose early sections cancel at low frequency:
//    Ahmad2020 K(s) at 10 kHz has N = 264 before a slow section of DC gain
//    5932, for an overall DC gain of 607.
//  * record truncation (frequency response only): the record stops where the
//    slowest pole has decayed to 1e-8; what it leaves out is below 1e-7 L1.
// Plain float32 DF2T, run here beside it, fails the same tolerances on the
// stiff cases by orders of magnitude (so the tests can fail).
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <complex>
#include <cstdio>
#include <fstream>
#include <string>
#include <vector>

#include <nlohmann/json.hpp>

#include "piezoloop/biquad.hpp"

using namespace piezoloop;

namespace {

using cplx = std::complex<double>;
constexpr double kTwoPi = 6.283185307179586476925;
constexpr double kU = 1.0 / 16777216.0;  // 2^-24

const nlohmann::json& golden() {
    static const nlohmann::json j = [] {
        std::ifstream f(std::string(PIEZOLOOP_GOLDEN_DIR) + "/stiff_sections_ref.json");
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

// sum over sections of (relative rounding) x (first-order sensitivity
// kappa), per the section's form (above).
double coefficient_bound(const std::vector<SosSection>& sos, const std::vector<SectionForm>& forms, double w) {
    const cplx d = std::polar(1.0, w) - 1.0;
    double sum = 0.0;
    for (size_t i = 0; i < sos.size(); ++i) {
        const SosSection& s = sos[i];
        const double c1 = s.a1 + 2.0, c0 = c1 + (s.a2 - 1.0);
        const double n1 = 2.0 * s.b0 + s.b1, n0 = (s.b0 + s.b1) + s.b2;
        const cplx D = d * d + c1 * d + c0;
        const double den = (std::fabs(c1) * std::abs(d) + std::fabs(c0)) / std::abs(D);
        if (forms[i] == SectionForm::kDf2t) {
            const cplx N = s.b0 * d * d + n1 * d + n0;
            sum += BiquadCascade<float, 1>::kDf2tTolerance *
                   ((std::fabs(n1) * std::abs(d) + std::fabs(n0)) / std::abs(N) + den);
        } else {
            const double g1 = n1 - s.b0 * c1, g0 = n0 - s.b0 * c0;
            const cplx G = g1 * d + g0;
            const double sens = std::fabs(s.b0) + (std::fabs(g1) * std::abs(d) + std::fabs(g0)) / std::abs(D) +
                                std::abs(G) * den / std::abs(D);
            sum += kU * sens / std::abs(s.b0 + G / D);
        }
    }
    return sum;
}

// sum_i N_i A_i of the arithmetic bound (above), in double over n samples.
double propagated_l1(const std::vector<SosSection>& sos, long n) {
    auto l1_of = [&](size_t first, size_t last) {  // sections [first, last)
        std::vector<std::array<double, 2>> st(sos.size(), {0.0, 0.0});
        double l1 = 0.0;
        for (long k = 0; k < n; ++k) {
            double x = k == 0 ? 1.0 : 0.0;
            for (size_t i = first; i < last; ++i) {
                const SosSection& q = sos[i];
                const double y = q.b0 * x + st[i][0];
                st[i][0] = q.b1 * x - q.a1 * y + st[i][1];
                st[i][1] = q.b2 * x - q.a2 * y;
                x = y;
            }
            l1 += std::fabs(x);
        }
        return l1;
    };
    double sum = 0.0;
    for (size_t i = 0; i < sos.size(); ++i) {
        const double in = l1_of(0, i), out = l1_of(0, i + 1);
        const double after = i + 1 < sos.size() ? l1_of(i + 1, sos.size()) : 1.0;
        sum += std::max(in, out) * after;
    }
    return sum;
}

// Plain float32 direct form II transposed (what the cascade used to be), to
// show the tolerances separate a fit realisation from an unfit one.
struct Df2tFloat {
    std::vector<std::array<float, 5>> c;
    std::vector<std::array<float, 2>> s;
    explicit Df2tFloat(const std::vector<SosSection>& sos) {
        for (const SosSection& q : sos) {
            c.push_back({float(q.b0), float(q.b1), float(q.b2), float(q.a1), float(q.a2)});
            s.push_back({0.0f, 0.0f});
        }
    }
    float apply(float x) {
        for (size_t i = 0; i < c.size(); ++i) {
            const float y = c[i][0] * x + s[i][0];
            s[i][0] = c[i][1] * x - c[i][3] * y + s[i][1];
            s[i][1] = c[i][2] * x - c[i][4] * y;
            x = y;
        }
        return x;
    }
};

template <class Filter>
std::vector<double> impulse(Filter& f, long n) {
    std::vector<double> h(static_cast<size_t>(n));
    for (long k = 0; k < n; ++k) h[static_cast<size_t>(k)] = f.apply(k == 0 ? 1.0f : 0.0f);
    return h;
}

// sum h[n] e^{-jwn}, the phasor re-seeded exactly every 1024 samples.
cplx dft_at(const std::vector<double>& h, double w) {
    cplx acc = 0.0, ph = 1.0;
    const cplx step = std::polar(1.0, -w);
    for (size_t n = 0; n < h.size(); ++n) {
        if ((n & 1023u) == 0) ph = std::polar(1.0, -w * static_cast<double>(n));
        acc += h[n] * ph;
        ph *= step;
    }
    return acc;
}

struct Worst {
    double impulse = 0.0;  // largest error / tolerance over the impulse samples
    double freq = 0.0;     // largest error / tolerance over the frequencies
    double db = 0.0, deg = 0.0;
};

// Error of a realisation's impulse and frequency response against scipy,
// as a fraction of the tolerance (<= 1 passes).
Worst compare(const nlohmann::json& c, const std::vector<double>& h, const std::vector<SectionForm>& forms) {
    const auto sos = sos_from(c["sos"]);
    const double l1 = c["impulse_l1"].get<double>();
    const double arith = 64.0 * kU * propagated_l1(sos, c["impulse_samples"].get<long>());
    Worst w;
    const auto idx = c["impulse_index"].get<std::vector<long>>();
    const auto ref = vec(c["impulse"]);
    const double tol_imp = arith;
    for (size_t i = 0; i < idx.size(); ++i)
        w.impulse = std::max(w.impulse, std::fabs(h[static_cast<size_t>(idx[i])] - ref[i]) / tol_imp);
    const auto f = vec(c["freqs_Hz"]);
    const auto re = vec(c["h_re"]), im = vec(c["h_im"]);
    const double fs = c["fs"].get<double>();
    for (size_t k = 0; k < f.size(); ++k) {
        const double om = kTwoPi * f[k] / fs;
        const cplx want(re[k], im[k]);
        const cplx got = dft_at(h, om);
        // Coefficients (relative), arithmetic summed over the record, truncation.
        const double tol = 2.0 * coefficient_bound(sos, forms, om) * std::abs(want) + arith + 1e-7 * l1;
        w.freq = std::max(w.freq, std::abs(got - want) / tol);
        const cplx r = got / want;
        w.db = std::max(w.db, std::fabs(20.0 * std::log10(std::abs(r))));
        w.deg = std::max(w.deg, std::fabs(std::arg(r)) * 180.0 / 3.14159265358979323846);
    }
    return w;
}

}  // namespace

TEST(BiquadStiff, FloatCascadeMatchesScipyImpulseAndFrequencyResponse) {
    for (const auto& c : golden()["cases"]) {
        const auto sos = sos_from(c["sos"]);
        const std::string name = c["name"].get<std::string>() + " at " +
                                 std::to_string(static_cast<int>(c["fs"].get<double>())) + " Hz";
        BiquadCascade<float, 4> f;
        ASSERT_TRUE(f.configure(sos.data(), static_cast<int>(sos.size()), {}, {}).ok()) << name;
        std::vector<SectionForm> forms;
        std::string form_names;
        for (int i = 0; i < f.count(); ++i) {
            forms.push_back(f.form(i));
            form_names += forms.back() == SectionForm::kDf2t ? " df2t" : " delta";
        }
        const std::vector<double> h = impulse(f, c["impulse_samples"].get<long>());
        const Worst w = compare(c, h, forms);
        std::printf("%-28s worst %.2g dB %.2g deg; error / tolerance: impulse %.2g, frequency %.2g; forms%s\n",
                    name.c_str(), w.db, w.deg, w.impulse, w.freq, form_names.c_str());
        // Each of these cases has a pole or zero close enough to z = 1 that
        // DF2T does not hold it: at least one delta section.
        EXPECT_NE(form_names.find("delta"), std::string::npos) << name;
        EXPECT_LE(w.impulse, 1.0) << name;
        EXPECT_LE(w.freq, 1.0) << name;
        // The figure of merit, implied by the above where it holds.
        EXPECT_LE(w.db, 0.1) << name;
        EXPECT_LE(w.deg, 1.0) << name;
    }
}

TEST(BiquadStiff, PlainFloatDf2tFailsTheSameTolerances) {
    // Ahmad2020 K(s): DF2T's float a1, a2 cannot hold its slow pole pair
    // (at 100 kHz the gain at 0.1 Hz is ~30 dB off); the PI-lead at 100 kHz
    // is ~1.8 dB off.
    int checked = 0;
    for (const auto& c : golden()["cases"]) {
        const bool k100 = c["name"] == "ahmad2020_K" && c["fs"].get<double>() == 1e5;
        const bool pi100 = c["name"] == "pi_lead" && c["fs"].get<double>() == 1e5;
        if (!k100 && !pi100) continue;
        const auto sos = sos_from(c["sos"]);
        Df2tFloat plain(sos);
        const Worst w = compare(c, impulse(plain, c["impulse_samples"].get<long>()),
                                std::vector<SectionForm>(sos.size(), SectionForm::kDelta));
        std::printf("%s at 100 kHz, plain float DF2T: %.3g dB %.3g deg; error / tolerance %.3g\n",
                    c["name"].get<std::string>().c_str(), w.db, w.deg, w.freq);
        if (k100) {
            EXPECT_GT(w.freq, 10.0);
        }
        EXPECT_GT(w.db, 1.0);
        ++checked;
    }
    EXPECT_EQ(checked, 2) << "cases missing from the fixture";
}
