// The uncertainty weight from a model's error on measured lines
// (host/commission/uncertainty_weight.hpp): it covers every coverable line,
// its corner is the largest that does (analytic: |W3(jω)| of a first-order
// lead), its levels are r0 and 2, and lines above 2 are counted.
#include <gtest/gtest.h>

#include <cmath>
#include <numbers>
#include <stdexcept>
#include <vector>

#include "commission/uncertainty_weight.hpp"
#include "lti/freqresp.hpp"

namespace piezoloop::commission {
namespace {

constexpr double kTwoPi = 2.0 * std::numbers::pi;

double magnitude(const design::Zpk& w, double f_Hz) { return std::abs(design::evaluate(w, design::cplx(0.0, kTwoPi * f_Hz))); }

TEST(UncertaintyWeight, CoversEveryLineWithTheLargestCorner) {
    // An error of 3 % that grows as f^2 from 300 Hz on, up to 150 %.
    std::vector<double> f, delta;
    for (double x = 10.0; x <= 4000.0; x *= 1.05) {
        f.push_back(x);
        delta.push_back(std::min(1.5, 0.03 * (1.0 + (x / 300.0) * (x / 300.0))));
    }
    const UncertaintyWeight u = uncertainty_weight(f, delta);
    EXPECT_NEAR(u.r0, 0.03 * (1.0 + std::pow(f[4] / 300.0, 2)), 1e-15);  // the fifth line's error, the largest of five
    EXPECT_EQ(u.uncovered_lines, 0);
    for (std::size_t i = 0; i < f.size(); ++i) EXPECT_GE(magnitude(u.w3, f[i]), delta[i] * (1.0 - 1e-12)) << f[i];
    // Levels: r0 at DC, 2 at high frequency (the zpk gain: r0 wp / wz).
    EXPECT_NEAR(magnitude(u.w3, 1e-6), u.r0, 1e-12);
    EXPECT_NEAR(u.w3.gain, 2.0, 1e-12);
    // The largest corner: 0.1 % higher and some line is above the weight.
    const double wz = u.wz_rad_s * 1.001, wp = wz * u.r_inf / u.r0;
    bool broken = false;
    for (std::size_t i = 0; i < f.size(); ++i) {
        const double w = kTwoPi * f[i];
        const double m = u.r0 * std::sqrt((1.0 + (w / wz) * (w / wz)) / (1.0 + (w / wp) * (w / wp)));
        broken = broken || m < delta[i];
    }
    EXPECT_TRUE(broken);
}

TEST(UncertaintyWeight, AFlatSmallErrorGivesTheFloorAndLinesAboveTwoAreCounted) {
    const std::vector<double> f{10.0, 100.0, 1000.0, 2000.0};
    UncertaintyWeight u = uncertainty_weight(f, {0.001, 0.001, 0.001, 0.001});
    EXPECT_DOUBLE_EQ(u.r0, 0.02);  // at least 2 %
    EXPECT_GT(u.wz_rad_s, kTwoPi * 2000.0);  // flat over the lines
    u = uncertainty_weight(f, {0.01, 0.01, 0.5, 3.0});
    EXPECT_EQ(u.uncovered_lines, 1);
    EXPECT_GE(magnitude(u.w3, 1000.0), 0.5);
}

TEST(UncertaintyWeight, RefusesBadLines) {
    EXPECT_THROW(uncertainty_weight({}, {}), std::invalid_argument);
    EXPECT_THROW(uncertainty_weight({10.0, 5.0}, {0.1, 0.1}), std::invalid_argument);
    EXPECT_THROW(uncertainty_weight({10.0, 20.0}, {0.1, NAN}), std::invalid_argument);
    EXPECT_THROW(uncertainty_weight({10.0}, {0.1, 0.2}), std::invalid_argument);
}

}  // namespace
}  // namespace piezoloop::commission
