// host/lti/realisation: the check runs the core's BiquadCascade itself.
// The canonical stiff case: Ahmad2020 K(s) at 100 kHz (slow pole pair at
// |z| ~ 0.99997), fit in float32 (its slow pair in the delta-operator form)
// and in Q31. The measurement itself is checked against an
// independent computation (the response of the float-rounded coefficients
// evaluated in double) on a well-conditioned filter, and configure()
// rejections are reported with the core's field names.
#include <gtest/gtest.h>

#include <cmath>
#include <cstdio>
#include <numbers>
#include <string>
#include <vector>

#include "lti/c2d.hpp"
#include "lti/filters.hpp"
#include "lti/freqresp.hpp"
#include "lti/model_json.hpp"
#include "lti/realisation.hpp"
#include "lti/sos.hpp"

using namespace piezoloop;
using namespace piezoloop::design;

namespace {

struct Design {
    Zpk zpk;
    std::vector<SosSection> sos;
};

// K(s) at 100 kHz, Tustin, scaled for 10 mV in / 10 V out (L1): the setup
// of tests/common/test_biquad.cpp.
Design ahmad_k() {
    Design d;
    d.zpk = tustin(load_model_file(std::string(PIEZOLOOP_GOLDEN_DIR) + "/../../configs/models/ahmad2020_K.json"),
                   1e-5);
    SosScaling sc;
    sc.in_full_scale = 0.01;
    sc.out_full_scale = 10.0;
    d.sos = scale_sos(zpk2sos(d.zpk), sc);
    return d;
}

bool any_contains(const std::vector<std::string>& v, const std::string& what) {
    for (const auto& s : v)
        if (s.find(what) != std::string::npos) return true;
    return false;
}

}  // namespace

TEST(DesignRealisation, AhmadKFloat32IsFit) {
    const Design d = ahmad_k();
    RealisationOptions o;
    o.format = SampleFormat::kFloat;
    o.in_full_scale = 0.01;
    o.out_full_scale = 10.0;
    const RealisationReport r = check_realisation(d.zpk, d.sos, o);
    ASSERT_TRUE(r.configured) << r.configure_error;
    EXPECT_TRUE(r.fit) << (r.warnings.empty() ? "" : r.warnings[0]);
    // c1 = 2 + a1 and c0 = 1 + a1 + a2 keep 24 significant bits each: the
    // slow pair moves by ~2^-24 of its distance to z = 1, far below 1 % of
    // its distance to the unit circle (plain float a1, a2 moved it ~7 times
    // that distance).
    EXPECT_LT(r.max_relative_pole_shift, 1e-4);
    EXPECT_LT(r.max_error_db, 0.1);
    EXPECT_LT(r.max_phase_error_deg, 1.0);
    ASSERT_EQ(r.section_forms.size(), d.sos.size());
    // The slow pair (last section) needs the delta form.
    EXPECT_NE(r.section_forms.back().find("delta operator"), std::string::npos) << r.section_forms.back();
    std::printf("Ahmad2020 K(s) at 100 kHz, float32: %.3g dB, %.3g deg, pole shift %.2g\n", r.max_error_db,
                r.max_phase_error_deg, r.max_relative_pole_shift);
}

TEST(DesignRealisation, AhmadKQ31IsFit) {
    const Design d = ahmad_k();
    RealisationOptions o;
    o.format = SampleFormat::kQ31;
    o.in_full_scale = 0.01;
    o.out_full_scale = 10.0;
    const RealisationReport r = check_realisation(d.zpk, d.sos, o);
    ASSERT_TRUE(r.configured) << r.configure_error;
    EXPECT_TRUE(r.fit) << (r.warnings.empty() ? "" : r.warnings[0]);
    // Q31 resolves 1 + a1 + a2 ~ 1.06e-9 of the slow section to 2^-44
    // (relative 5.4e-5, tests/common/test_biquad.cpp): the pole moves by
    // ~6e-5 of its distance to the circle; 1e-3 allows 15x.
    EXPECT_LT(r.max_relative_pole_shift, 1e-3);
    // The same 5.4e-5 relative on the slow section's gain, amplified near
    // its resonance, plus the DFT noise of the ~8.7e5-sample record: the
    // response stays within 0.01 dB (observed ~0.0025 dB) and 0.1 deg.
    EXPECT_LT(r.max_error_db, 0.01);
    EXPECT_LT(r.max_phase_error_deg, 0.1);
    // Points where the design's gain in sample units is within 300x of
    // the record's noise (K's notch-like dip to -24 dB around 300 Hz … 2.5
    // kHz, and Tustin's zero at Nyquist) are listed but not counted; every
    // point below 200 Hz, where the slow section matters, is counted.
    int counted = 0;
    for (const auto& p : r.response) {
        counted += p.counted;
        if (p.f_hz < 200.0) {
            EXPECT_TRUE(p.counted) << p.f_hz;
        }
    }
    EXPECT_GE(counted, 40);  // observed 49 of 61
}

TEST(DesignRealisation, AhmadKQ31WithThePipelinesScalesIsFit) {
    // The ahmad2020 scenario's K(s) as the Q31 pipeline runs it: 10 kHz,
    // Tustin, error in µm (K times the sensor's 1/3 V/µm) on the 40 µm
    // position scale, command on the 16 V voltage scale, L1-scaled. The
    // controller's gain between these samples (~500 at its L1 norm) lands in
    // the last section's numerator (sum|b| ~ 440, the high-gain Q31 kernel),
    // whose gain also amplifies the earlier sections' rounding to a
    // limit cycle of ~200 LSB (1.5 µV): the noise model accounts for it.
    Zpk k = load_model_file(std::string(PIEZOLOOP_GOLDEN_DIR) + "/../../configs/models/ahmad2020_K.json");
    k.gain /= 3.0;
    const Zpk zd = tustin(k, 1e-4);
    SosScaling sc;
    sc.in_full_scale = 40.0;
    sc.out_full_scale = 16.0;
    const std::vector<SosSection> sos = scale_sos(zpk2sos(zd), sc);
    const double sum_b_last = std::fabs(sos.back().b0) + std::fabs(sos.back().b1) + std::fabs(sos.back().b2);
    EXPECT_GT(sum_b_last, 8.0);  // beyond the plain (right-shift) numerator range
    RealisationOptions o;
    o.format = SampleFormat::kQ31;
    o.in_full_scale = 40.0;
    o.out_full_scale = 16.0;
    const RealisationReport r = check_realisation(zd, sos, o);
    ASSERT_TRUE(r.configured) << r.configure_error;
    EXPECT_TRUE(r.fit) << (r.warnings.empty() ? "" : r.warnings[0]);
    // At 10 kHz the slow pair sits at |z| = 0.99968: 1 + a1 + a2 ~ 1.05e-7,
    // resolved to 2^-40 (c1, c2 ~ 6.4e-4 take exponent -9), ~1e-5 relative
    // (observed pole shift 1.1e-5 of the distance to the circle); the
    // response (observed 0.001 dB, 0.006 deg, at ~1.7 kHz where the
    // record's noise is largest) within 0.01 dB and 0.1 deg.
    EXPECT_LT(r.max_relative_pole_shift, 1e-3);
    EXPECT_LT(r.max_error_db, 0.01);
    EXPECT_LT(r.max_phase_error_deg, 0.1);
    int counted = 0;
    for (const auto& p : r.response) counted += p.counted;
    EXPECT_GE(counted, 40);  // observed 59 of 61
}

TEST(DesignRealisation, Q31NoiseAmplificationMatchesClosedForms) {
    // Reference: ||(1 - z^-1)^2 H||_2^2 in closed form. A lone section: 6
    // (1 + 4 + 1), so the amplification is 1 whatever the section. A pure
    // gain g after it: 6 g^2 more. A first-order low-pass 1 / (1 - p z^-1)
    // after it: the response 1, p - 2, then p^(k-2) (1 - p)^2, energy
    // 1 + (p - 2)^2 + (1 - p)^4 / (1 - p^2). Double rounding and the cut
    // after 2000 samples (p^4000) are ~1e-15 relative: 1e-12 allows for it.
    const SosSection any{0.3, -0.1, 0.2, -1.2, 0.5};
    EXPECT_NEAR(q31_noise_amplification({any}, 2000), 1.0, 1e-12);
    const double g = 440.0;
    EXPECT_NEAR(q31_noise_amplification({any, SosSection{g, 0.0, 0.0, 0.0, 0.0}}, 2000),
                std::sqrt(1.0 + g * g), 1e-12 * g);
    const double p = 0.5;
    const double lp = 1.0 + (p - 2.0) * (p - 2.0) + std::pow(1.0 - p, 4) / (1.0 - p * p);
    EXPECT_NEAR(q31_noise_amplification({any, SosSection{1.0, 0.0, 0.0, -p, 0.0}}, 2000),
                std::sqrt((6.0 + lp) / 6.0), 1e-12);
}

TEST(DesignRealisation, MeasurementMatchesRoundedCoefficientsResponse) {
    // A 1 kHz notch at 100 kHz (well conditioned). The DFT of the float
    // cascade's impulse response must equal the response of the
    // float-rounded coefficients evaluated in double, up to float
    // arithmetic noise: ~2^-24 per sample (|h| <= 1 here) summed over the
    // record, sqrt(n) 2^-24; 4 times that.
    const Zpk z = notch(NotchSpec{1e3, -30.0, 200.0}, 1e5);
    const std::vector<SosSection> sos = zpk2sos(z);
    RealisationOptions o;
    o.format = SampleFormat::kFloat;
    const RealisationReport r = check_realisation(z, sos, o);
    ASSERT_TRUE(r.configured);
    EXPECT_TRUE(r.fit);
    // The section as the core stores it (b0, g1, g0, c1, c0 in float; see
    // BiquadCascade<float>), turned back into z-domain coefficients in double.
    std::vector<SosSection> rounded = sos;
    for (SosSection& s : rounded) {
        const double c1 = static_cast<float>(s.a1 + 2.0);
        const double c0 = static_cast<float>((s.a1 + 2.0) + (s.a2 - 1.0));
        const double b0 = static_cast<float>(s.b0);
        const double g1 = static_cast<float>((2.0 * s.b0 + s.b1) - s.b0 * (s.a1 + 2.0));
        const double g0 = static_cast<float>((s.b0 + s.b1 + s.b2) - s.b0 * ((s.a1 + 2.0) + (s.a2 - 1.0)));
        const double n1 = g1 + b0 * c1, n0 = g0 + b0 * c0;  // N = b0 d^2 + n1 d + n0
        s = SosSection{b0, n1 - 2.0 * b0, n0 - n1 + b0, c1 - 2.0, c0 - c1 + 1.0};
    }
    const double tol = 4.0 * std::sqrt(static_cast<double>(r.impulse_samples)) * std::ldexp(1.0, -24);
    for (const ResponsePoint& p : r.response) {
        const cplx want = freqresp(rounded, z.ts, {2.0 * std::numbers::pi * p.f_hz})[0];
        EXPECT_NEAR(std::abs(p.realised - want), 0.0, tol) << p.f_hz;
    }
    // And Q31 of the same filter: fit, errors below 1e-3 dB.
    o.format = SampleFormat::kQ31;
    const RealisationReport q = check_realisation(z, sos, o);
    EXPECT_TRUE(q.fit);
    EXPECT_LT(q.max_error_db, 1e-3);
}

TEST(DesignRealisation, ConfigureRejectionsAreReported) {
    // Q31: a numerator with sum |b| >= 2^24 (a 1 kHz low-pass's 0.0036 times 1e11).
    const Zpk z = lowpass(LowpassSpec{1e3, 0.7}, 1e5);
    std::vector<SosSection> sos = zpk2sos(z);
    for (SosSection& s : sos) {
        s.b0 *= 1e11;
        s.b1 *= 1e11;
        s.b2 *= 1e11;
    }
    Zpk big = z;
    big.gain *= 1e11;
    RealisationOptions o;
    o.format = SampleFormat::kQ31;
    const RealisationReport r = check_realisation(big, sos, o);
    EXPECT_FALSE(r.configured);
    EXPECT_FALSE(r.fit);
    EXPECT_NE(r.configure_error.find("sections[0].b0"), std::string::npos) << r.configure_error;
    // float: a pole pair at +-j, 5e-10 inside the unit circle: no float form
    // holds it (c0 = 1 + a1 + a2 = 2 - 1e-9 rounds to c1 = 2, i.e. a2 = 1).
    // Near z = 1 the same distance is fine (c1, c0 are small and kept).
    const SosSection tight{1.0, 0.0, 0.0, 0.0, 1.0 - 1e-9};
    const Zpk tz{{}, {cplx(0.0, 1.0 - 5e-10), cplx(0.0, -(1.0 - 5e-10))}, 1.0, 1e-5};
    o.format = SampleFormat::kFloat;
    const RealisationReport f = check_realisation(tz, {tight}, o);
    EXPECT_FALSE(f.configured);
    EXPECT_NE(f.configure_error.find("sections[0].a2"), std::string::npos) << f.configure_error;
    EXPECT_TRUE(any_contains(f.warnings, "--format q31"));
}
