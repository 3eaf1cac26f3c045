// host/lti/filters: notch, low-pass and lead-lag against their analytic
// properties, continuous and after pre-warped Tustin.
#include <gtest/gtest.h>

#include <cmath>
#include <numbers>
#include <stdexcept>
#include <string>

#include "lti/filters.hpp"
#include "lti/freqresp.hpp"

using namespace piezoloop::design;

namespace {

constexpr double kTwoPi = 2.0 * std::numbers::pi;

double mag_c(const Zpk& z, double f_hz) { return std::abs(evaluate(z, cplx(0.0, kTwoPi * f_hz))); }
double mag_d(const Zpk& z, double f_hz) { return std::abs(freqresp(z, {kTwoPi * f_hz})[0]); }

std::string error_of(auto f) {
    try {
        f();
    } catch (const std::invalid_argument& e) {
        return e.what();
    }
    return "no error";
}

}  // namespace

TEST(DesignFilters, NotchDepthAndWidth) {
    const NotchSpec s{18e3, -40.0, 2e3};
    const Zpk c = notch_continuous(s);
    // Depth at f0: zz / zp exactly (roots rounded: 1e-12 relative).
    EXPECT_NEAR(mag_c(c, s.frequency_hz), 0.01, 1e-14);
    // The two -3 dB points are f0 (sqrt(1 + q^2) -+ q), q = width / (2 f0),
    // exactly width apart.
    const double q = s.width_hz / (2.0 * s.frequency_hz);
    const double f1 = s.frequency_hz * (std::sqrt(1.0 + q * q) - q), f2 = f1 + s.width_hz;
    EXPECT_NEAR(mag_c(c, f1), 1.0 / std::sqrt(2.0), 1e-12);
    EXPECT_NEAR(mag_c(c, f2), 1.0 / std::sqrt(2.0), 1e-12);
    EXPECT_NEAR(mag_c(c, 1.0), 1.0, 1e-9);  // unity far below
    // Discrete at 100 kHz, pre-warped at f0: the depth is exact at f0, unity
    // at DC and at Nyquist (s = infinity maps to z = -1).
    const Zpk d = notch(s, 1e5);
    EXPECT_NEAR(mag_d(d, s.frequency_hz), 0.01, 1e-12);
    EXPECT_NEAR(std::abs(dc_gain(d)), 1.0, 1e-13);
    EXPECT_NEAR(mag_d(d, 0.5e5), 1.0, 1e-12);
    // The -3 dB points move by the warping away from f0 but stay near.
    EXPECT_LT(mag_d(d, f1 * 0.98), 1.0);
    EXPECT_GT(mag_d(d, f1 * 0.9), 1.0 / std::sqrt(2.0));
}

TEST(DesignFilters, LowpassCornerAndQ) {
    const LowpassSpec s{5e3, 2.0};
    const Zpk c = lowpass_continuous(s);
    EXPECT_NEAR(dc_gain(c), 1.0, 1e-14);
    EXPECT_NEAR(mag_c(c, s.frequency_hz), s.q, 1e-12);  // |H(j w0)| = Q
    EXPECT_NEAR(-c.poles[0].real() / std::abs(c.poles[0]), 1.0 / (2.0 * s.q), 1e-14);
    const Zpk d = lowpass(s, 1e5);
    EXPECT_NEAR(dc_gain(d), 1.0, 1e-13);
    EXPECT_NEAR(mag_d(d, s.frequency_hz), s.q, 1e-11);  // pre-warped: exact at f0
    EXPECT_LT(mag_d(d, 0.5e5 * 0.999), 1e-3);           // double zero at Nyquist
    // Overdamped (Q < 0.5): two real poles.
    const Zpk od = lowpass_continuous(LowpassSpec{1e3, 0.3});
    EXPECT_EQ(od.poles[0].imag(), 0.0);
    EXPECT_NEAR(mag_c(od, 1e3), 0.3, 1e-12);
}

TEST(DesignFilters, LeadLag) {
    const LeadLagSpec s{100.0, 1e3, 2.0};  // lead: zero below pole
    const Zpk c = leadlag_continuous(s);
    EXPECT_NEAR(dc_gain(c), 2.0, 1e-14);
    const double fc = std::sqrt(s.zero_hz * s.pole_hz);
    const double lead = std::asin((s.pole_hz - s.zero_hz) / (s.pole_hz + s.zero_hz)) * 180.0 / std::numbers::pi;
    EXPECT_NEAR(phase_deg(evaluate(c, cplx(0.0, kTwoPi * fc))), lead, 1e-10);
    const Zpk d = leadlag(s, 1e4);
    EXPECT_NEAR(dc_gain(d), 2.0, 1e-13);
    // High-frequency gain gain * fp / fz appears at Nyquist.
    EXPECT_NEAR(mag_d(d, 0.5e4), 2.0 * 10.0, 1e-10);
    // Pre-warped at the centre: the maximum phase lead lands there exactly.
    EXPECT_NEAR(phase_deg(freqresp(d, {kTwoPi * fc})[0]), lead, 1e-9);
}

TEST(DesignFilters, ErrorsNameTheParameter) {
    EXPECT_NE(error_of([] { notch(NotchSpec{6e4, -40.0, 100.0}, 1e5); }).find("frequency_hz"), std::string::npos);
    EXPECT_NE(error_of([] { notch(NotchSpec{1e3, -2.0, 100.0}, 1e5); }).find("depth_db"), std::string::npos);
    EXPECT_NE(error_of([] { notch(NotchSpec{1e3, -40.0, 0.0}, 1e5); }).find("width_hz"), std::string::npos);
    EXPECT_NE(error_of([] { lowpass(LowpassSpec{1e3, 0.0}, 1e5); }).find("q"), std::string::npos);
    EXPECT_NE(error_of([] { lowpass(LowpassSpec{1e3, 1.0}, -5.0); }).find("rate_hz"), std::string::npos);
    EXPECT_NE(error_of([] { leadlag(LeadLagSpec{10.0, 100.0, 0.0}, 1e4); }).find("gain"), std::string::npos);
    EXPECT_NE(error_of([] { leadlag(LeadLagSpec{10.0, 6e3, 1.0}, 1e4); }).find("pole_hz"), std::string::npos);
}
