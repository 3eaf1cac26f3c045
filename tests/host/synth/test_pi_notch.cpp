// synth/pi_notch against analytic loops: the gain and phase of L = G K at the
// crossover are computed here from the formulas, not by the library.
#include <gtest/gtest.h>

#include <cmath>
#include <numbers>

#include "synth/pi_notch.hpp"

namespace piezoloop::design {
namespace {

constexpr double kTwoPi = 2.0 * std::numbers::pi;
constexpr double kDeg = 180.0 / std::numbers::pi;

TEST(PiNotch, FirstOrderPlantGetsTheAnalyticGainAndPhaseMargin) {
    // G = 1/(s+1), w_c = 10 rad/s, w_i = 2.5, leak w_l = 1e-3: kp =
    // |j10 + 1| |j10 + 1e-3| / |j10 + 2.5|, PM = 180 + atan(10/2.5) -
    // atan(10/1e-3) - atan(10) degrees, no phase crossover.
    const Zpk g{{}, {cplx(-1.0)}, 1.0, 0.0};
    const PiNotchDesign d = design_pi_notch(g, 10.0 / kTwoPi);
    EXPECT_NEAR(d.kp, std::abs(cplx(1.0, 10.0)) * std::abs(cplx(1e-3, 10.0)) / std::abs(cplx(2.5, 10.0)), 1e-12);
    EXPECT_NEAR(d.integral_Hz, 2.5 / kTwoPi, 1e-12);
    EXPECT_DOUBLE_EQ(d.crossover_Hz, 10.0 / kTwoPi);
    // The library's margin search refines to 1e-12 relative in frequency.
    EXPECT_NEAR(d.phase_margin_deg, 180.0 + (std::atan(4.0) - std::atan(1e4) - std::atan(10.0)) * kDeg, 1e-6);
    EXPECT_TRUE(std::isinf(d.gain_margin_db));
    EXPECT_TRUE(d.notches.empty());
    EXPECT_TRUE(d.warnings.empty());
}

TEST(PiNotch, ALightlyDampedModeAboveCrossoverIsNotched) {
    // G = a/(s+a) · wn²/(s² + 2 ζ wn s + wn²), a = 2π 50, wn = 2π 1000, ζ = 0.01;
    // target 20 Hz. The notch's zeros are G's pole pair, so
    // L = kp (s + w_i)/(s + w_l) · a/(s+a) · wn²/(s² + 1.4 wn s + wn²), w_l = 1e-4 w_c.
    const double a = kTwoPi * 50.0, wn = kTwoPi * 1000.0, z = 0.01;
    const cplx p(-z * wn, wn * std::sqrt(1.0 - z * z));
    const Zpk g{{}, {cplx(-a), p, std::conj(p)}, a * wn * wn, 0.0};
    const PiNotchDesign d = design_pi_notch(g, 20.0);
    ASSERT_EQ(d.notches.size(), 1u);
    EXPECT_NEAR(d.notches[0].f_Hz, 1000.0, 1e-9);
    EXPECT_NEAR(d.notches[0].plant_damping, z, 1e-12);
    const double wc = kTwoPi * d.crossover_Hz, wi = wc / 4.0;
    const cplx s(0.0, wc);
    const cplx l = d.kp * (s + wi) / (s + 1e-4 * wc) * a / (s + a) * wn * wn / (s * s + 1.4 * wn * s + wn * wn);
    EXPECT_NEAR(std::abs(l), 1.0, 1e-9);
    EXPECT_DOUBLE_EQ(d.crossover_Hz, 20.0);
    EXPECT_NEAR(d.phase_margin_deg, 180.0 + std::arg(l) * kDeg, 1e-6);
    EXPECT_GE(d.gain_margin_db, 6.0);
}

TEST(PiNotch, TheCrossoverIsLoweredUntilTheMarginsHold) {
    // G = 1/(s+1)^3 at a 2 rad/s crossover has PM < 0; the design comes down.
    const Zpk g{{}, {cplx(-1.0), cplx(-1.0), cplx(-1.0)}, 1.0, 0.0};
    const PiNotchDesign d = design_pi_notch(g, 2.0 / kTwoPi);
    EXPECT_LT(d.crossover_Hz, d.target_Hz);
    EXPECT_GE(d.phase_margin_deg, 45.0);
    EXPECT_GE(d.gain_margin_db, 6.0);
    const double wc = kTwoPi * d.crossover_Hz;
    const cplx s(0.0, wc);
    const cplx l = d.kp * (s + wc / 4.0) / (s + 1e-4 * wc) / ((s + 1.0) * (s + 1.0) * (s + 1.0));
    EXPECT_NEAR(std::abs(l), 1.0, 1e-9);
    EXPECT_NEAR(d.phase_margin_deg, 180.0 + std::arg(l) * kDeg, 1e-6);
    // One step (x 0.9) higher would miss PM >= 45: the search stops at the first that holds.
    const double w_up = wc / 0.9;
    const cplx su(0.0, w_up);
    const cplx lu = (su + w_up / 4.0) / (su + 1e-4 * w_up) / ((su + 1.0) * (su + 1.0) * (su + 1.0));
    EXPECT_LT(180.0 + std::arg(lu) * kDeg, 45.0);
    ASSERT_FALSE(d.warnings.empty());
    EXPECT_NE(d.warnings[0].find("lowered"), std::string::npos);
}

TEST(PiNotch, BadInputNamesTheField) {
    const Zpk stable{{}, {cplx(-1.0)}, 1.0, 0.0};
    EXPECT_THROW(design_pi_notch(Zpk{{}, {cplx(1.0)}, 1.0, 0.0}, 1.0), std::invalid_argument);
    EXPECT_THROW(design_pi_notch(Zpk{{}, {cplx(0.5)}, 1.0, 1e-3}, 1.0), std::invalid_argument);
    EXPECT_THROW(design_pi_notch(stable, 0.0), std::invalid_argument);
    PiNotchOptions nan_pm;
    nan_pm.pm_min_deg = NAN;
    EXPECT_THROW(design_pi_notch(stable, 1.0, nan_pm), std::invalid_argument);
    PiNotchOptions negative_gm;
    negative_gm.gm_min_db = -1.0;
    EXPECT_THROW(design_pi_notch(stable, 1.0, negative_gm), std::invalid_argument);
    PiNotchOptions impossible;
    impossible.pm_min_deg = 179.0;
    try {
        design_pi_notch(stable, 1.0, impossible);
        FAIL() << "PM >= 179 deg cannot be met";
    } catch (const std::invalid_argument& e) {
        EXPECT_NE(std::string(e.what()).find("crossover_hz"), std::string::npos);
    }
}

}  // namespace
}  // namespace piezoloop::design
