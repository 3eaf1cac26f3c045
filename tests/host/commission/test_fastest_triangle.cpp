// fastest_triangle: the fastest whole-range triangle within a tolerance,
// against closed forms of the power law it interpolates.
#include <gtest/gtest.h>

#include <cmath>
#include <stdexcept>

#include "commission/fastest_triangle.hpp"

namespace piezoloop::commission {
namespace {

TEST(FastestTriangle, ProportionalErrorMeetsTheToleranceWhereItsLineDoes) {
    // e = 0.5 % at 1 Hz growing as f: 1 % at exactly 2 Hz.
    const FastestTriangle r = fastest_triangle({{10.0, 5.0}, {1.0, 0.5}, {30.0, 15.0}});
    EXPECT_NEAR(r.up_to_Hz, 2.0, 1e-12);
    EXPECT_FALSE(r.at_least);
}

TEST(FastestTriangle, PowerLawBetweenTheRunsEitherSide) {
    // From 0.2 % at 1 Hz to 5 % at 10 Hz: e = 0.2 f^k, k = log10(25);
    // 1 % at f = 5^(1/k) = 10^(log10 5 / log10 25) = sqrt(10).
    const FastestTriangle r = fastest_triangle({{1.0, 0.2}, {10.0, 5.0}});
    EXPECT_NEAR(r.up_to_Hz, 3.1622776601683795, 1e-12);
    // A 2 % tolerance on the same runs: f = 10^(log10 10 / log10 25).
    EXPECT_NEAR(fastest_triangle({{1.0, 0.2}, {10.0, 5.0}}, 2.0).up_to_Hz, 5.1920429814029, 1e-12);
}

TEST(FastestTriangle, AllWithinIsAtLeastTheFastestNoneWithinIsZero) {
    const FastestTriangle all = fastest_triangle({{1.0, 0.1}, {10.0, 0.3}, {80.0, 0.9}});
    EXPECT_TRUE(all.at_least);
    EXPECT_EQ(all.up_to_Hz, 80.0);
    const FastestTriangle none = fastest_triangle({{1.0, 1.5}, {10.0, 9.0}});
    EXPECT_FALSE(none.at_least);
    EXPECT_EQ(none.up_to_Hz, 0.0);
    EXPECT_NE(describe(none).find("not within 1 % even at 1 Hz"), std::string::npos);
    EXPECT_NE(describe(all).find("up to at least 80 Hz"), std::string::npos);
}

TEST(FastestTriangle, AnErrorOfZeroStillInterpolates) {
    // The slower run exactly zero: the line starts at a thousandth of the
    // tolerance there, e = 1e-3 (f / 1)^k through 4 % at 10 Hz, k = log10(4000).
    const FastestTriangle r = fastest_triangle({{1.0, 0.0}, {10.0, 4.0}});
    EXPECT_NEAR(r.up_to_Hz, std::pow(10.0, 3.0 / std::log10(4000.0)), 1e-9);
}

TEST(FastestTriangle, BadInputNamesTheField) {
    auto message = [](std::vector<TrackingPoint> p, double tol) {
        try {
            (void)fastest_triangle(std::move(p), tol);
        } catch (const std::invalid_argument& e) {
            return std::string(e.what());
        }
        return std::string("no error");
    };
    EXPECT_EQ(message({}, 1.0).rfind("points:", 0), 0u);
    EXPECT_EQ(message({{1.0, 0.1}}, 0.0).rfind("tolerance_pct:", 0), 0u);
    EXPECT_EQ(message({{0.0, 0.1}}, 1.0).rfind("frequency_Hz:", 0), 0u);
    EXPECT_EQ(message({{1.0, -0.1}}, 1.0).rfind("e_max_pct:", 0), 0u);
    EXPECT_EQ(message({{1.0, 0.1}, {1.0, 0.2}}, 1.0).rfind("frequency_Hz:", 0), 0u);
}

}  // namespace
}  // namespace piezoloop::commission
