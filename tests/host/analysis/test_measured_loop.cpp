// analysis/measured_loop against analytic margins. L(s) = k / (s + 1)^3:
// the phase is -3 atan(w), so the phase crossover is at w = sqrt(3) with
// |L| = k / 8 (GM = 8 / k), and |L| = 1 at w_c = sqrt(k^(2/3) - 1) with
// PM = 180 - 3 atan(w_c) degrees.
#include <gtest/gtest.h>

#include <cmath>
#include <numbers>
#include <vector>

#include "analysis/measured_loop.hpp"

namespace piezoloop::design {
namespace {

constexpr double kTwoPi = 2.0 * std::numbers::pi;

// "Measured" lines of k / (s + 1)^3 (s in rad/s), n per decade from f_lo to f_hi Hz.
void lines(double k, double f_lo, double f_hi, int per_decade, std::vector<double>& f, std::vector<cplx>& g) {
    const int n = static_cast<int>(std::round(std::log10(f_hi / f_lo) * per_decade));
    for (int i = 0; i <= n; ++i) {
        const double fi = f_lo * std::pow(10.0, static_cast<double>(i) / per_decade);
        const cplx s(0.0, kTwoPi * fi);
        f.push_back(fi);
        g.push_back(k / ((s + 1.0) * (s + 1.0) * (s + 1.0)));
    }
}

TEST(MeasuredLoop, MarginsOfAThirdOrderLagAgreeWithTheAnalyticValues) {
    const double k = 4.0;
    std::vector<double> f;
    std::vector<cplx> g;
    lines(k, 0.001, 10.0, 200, f, g);
    const Zpk unity{{}, {}, 1.0, 0.0};
    const MeasuredLoop m = measured_loop(f, g, unity);
    const double wc = std::sqrt(std::pow(k, 2.0 / 3.0) - 1.0);
    const double pm = 180.0 - 3.0 * std::atan(wc) * 180.0 / std::numbers::pi;
    ASSERT_TRUE(m.phase_margin && m.gain_margin);
    // Linear interpolation between lines 200 per decade apart (1.2 % in f):
    // the crossing frequency within 1e-3 relative, PM within 0.01 degrees,
    // GM within 0.005 dB (the curvature of log|L| and phase over one step).
    EXPECT_NEAR(m.phase_margin->f_Hz, wc / kTwoPi, 1e-3 * wc / kTwoPi);
    EXPECT_NEAR(m.phase_margin->value, pm, 0.01);
    EXPECT_NEAR(m.gain_margin->f_Hz, std::sqrt(3.0) / kTwoPi, 1e-3 * std::sqrt(3.0) / kTwoPi);
    EXPECT_NEAR(m.gain_margin->value, 20.0 * std::log10(8.0 / k), 0.005);
    EXPECT_EQ(m.gain_crossovers.size(), 1u);
    EXPECT_EQ(m.phase_crossovers.size(), 1u);
    EXPECT_TRUE(m.warnings.empty());
    // max |S| over the lines: the analytic peak lies between lines, so the
    // lines' maximum is at most it and within 0.1 % of it at this density.
    double s_peak = 0.0;
    for (int i = 0; i <= 200000; ++i) {
        const cplx s(0.0, 0.01 * std::pow(10.0, 4.0 * i / 200000.0));
        s_peak = std::max(s_peak, 1.0 / std::abs(1.0 + k / ((s + 1.0) * (s + 1.0) * (s + 1.0))));
    }
    EXPECT_LE(m.max_sensitivity, s_peak * (1.0 + 1e-12));
    EXPECT_GT(m.max_sensitivity, s_peak * 0.999);
}

TEST(MeasuredLoop, TheControllerMultipliesTheLinesAndCoarseLinesAreReported) {
    // Plant 1/(s+1)^3 and a controller K = 4: the same loop as above.
    std::vector<double> f;
    std::vector<cplx> g;
    lines(1.0, 0.001, 10.0, 5, f, g);  // five lines per decade: coarse around the crossings
    const MeasuredLoop m = measured_loop(f, g, Zpk{{}, {}, 4.0, 0.0});
    ASSERT_TRUE(m.phase_margin);
    EXPECT_NEAR(m.phase_margin->value, 27.1, 3.0);  // coarse, but close
    ASSERT_FALSE(m.warnings.empty());
    EXPECT_NE(m.warnings.back().find("coarsely"), std::string::npos);
}

TEST(MeasuredLoop, NoCrossoverInTheBandIsSaid) {
    std::vector<double> f;
    std::vector<cplx> g;
    lines(4.0, 0.001, 0.05, 50, f, g);  // |L| > 1 on every line
    const MeasuredLoop m = measured_loop(f, g, Zpk{{}, {}, 1.0, 0.0});
    EXPECT_FALSE(m.phase_margin);
    ASSERT_FALSE(m.warnings.empty());
    EXPECT_NE(m.warnings.front().find("no gain crossover"), std::string::npos);
}

TEST(MeasuredLoop, BadInputNamesTheField) {
    const Zpk unity{{}, {}, 1.0, 0.0};
    EXPECT_THROW(measured_loop({1.0}, {cplx(1.0)}, unity), std::invalid_argument);
    EXPECT_THROW(measured_loop({2.0, 1.0}, {cplx(1.0), cplx(1.0)}, unity), std::invalid_argument);
    EXPECT_THROW(measured_loop({1.0, 2.0}, {cplx(1.0), cplx(NAN)}, unity), std::invalid_argument);
    try {
        measured_loop({100.0, 200.0}, {cplx(1.0), cplx(1.0)}, Zpk{{}, {}, 1.0, 1.0 / 300.0});
        FAIL() << "a line above the controller's Nyquist frequency";
    } catch (const std::invalid_argument& e) {
        EXPECT_NE(std::string(e.what()).find("controller"), std::string::npos);
    }
}

}  // namespace
}  // namespace piezoloop::design
