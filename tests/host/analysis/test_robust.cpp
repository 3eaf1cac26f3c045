// Coefficient-family robustness (robust.hpp): an analytic first-order family
// and Ahmad2020's 729 plants against numpy (tools/ref/analysis_robust.py).
#include <cmath>
#include <fstream>

#include <gtest/gtest.h>
#include <nlohmann/json.hpp>

#include "analysis/analysis.hpp"
#include "lti/lti_convert.hpp"
#include "analysis/robust.hpp"

using namespace piezoloop::design;

namespace {

Zpk gain(double k) {
    Zpk g;
    g.gain = k;
    return g;
}

std::vector<double> scale_of(int index, int n, double rel) {
    std::vector<double> s;
    for (int j = 0; j < n; ++j) {
        s.push_back(1.0 + rel * (index % 3 - 1));
        index /= 3;
    }
    return s;
}

// H_m of Ahmad2020 (docs/models.md, 'Ahmad2020') from its published parameters, factored.
Zpk ahmad_hm() {
    std::vector<Zpk> f;
    auto quad = [](double num1, double num0, double den1, double den0) {
        return tf2zpk(Tf{{1.0, num1, num0}, {1.0, den1, den0}});
    };
    const double w1 = 6.3e3, w2 = 1.4e4;
    f.push_back(quad(2 * 3.5 * w1, w1 * w1, 2 * 0.05 * w1, w1 * w1));
    f.push_back(quad(2 * 0.7 * w2, w2 * w2, 2 * 0.08 * w2, w2 * w2));
    f.push_back(tf2zpk(Tf{{1e-8, 1e4}, {1.0, 1e4}}));
    f.push_back(gain(0.02));
    return series(f);
}

}  // namespace

// G = 1/(s + a), K = k, H_m = h: members a_i = a (1 ± rel), a; closed-loop
// pole −(a_i + k) (worst −(a (1 − rel) + k)); |G_i/G − 1| = |a − a_i|/|jω + a_i|
// is largest at ω = 0, rel/(1 − rel) for a_i = a (1 − rel), so the coverage
// is rel/((1 − rel) h); ||H_m T_i|| = h k/(a_i + k), largest for the smallest
// a_i. Tolerances 1e-9 (eigenvalues of a 1x1 loop, golden-section search at
// the grid's low end for the coverage, H∞ certified to 2e-6 relative).
TEST(AnalysisRobust, FirstOrderFamilyAnalytic) {
    const double a = 100.0, k = 50.0, h = 0.2, rel = 0.05;
    const FamilyResult r = coefficient_family(Tf{{1.0}, {1.0, a}}, gain(k), gain(h), rel);
    EXPECT_EQ(r.count, 3);
    EXPECT_EQ(r.unstable, 0);
    EXPECT_NEAR(r.worst_stability.stability_measure, -(a * (1 - rel) + k), 1e-9);
    ASSERT_EQ(r.worst_stability.scale.size(), 1u);
    EXPECT_DOUBLE_EQ(r.worst_stability.scale[0], 1 - rel);
    EXPECT_NEAR(r.worst_coverage.coverage, rel / ((1 - rel) * h), 1e-6 * rel / ((1 - rel) * h));
    EXPECT_NEAR(r.worst_hinf_HmT.hinf_HmT, h * k / (a * (1 - rel) + k), 4e-6 * h);
}

TEST(AnalysisRobust, RejectsBadInput) {
    EXPECT_THROW(coefficient_family(Tf{{1.0}, {0.0, 1.0}}, gain(1), gain(1)), std::invalid_argument);
    EXPECT_THROW(coefficient_family(Tf{{1.0}, {1.0, 1.0}}, gain(1), gain(1), 0.7), std::invalid_argument);
    EXPECT_THROW(coefficient_family(Tf{{1.0}, {1.0, 1, 1, 1, 1, 1, 1, 1, 1, 1}}, gain(1), gain(1)),
                 std::invalid_argument);
    Zpk kd = gain(1);
    kd.ts = 1e-3;
    EXPECT_THROW(coefficient_family(Tf{{1.0}, {1.0, 1.0}}, kd, gain(1)), std::invalid_argument);
}

// Ahmad2020: G (eq. 4), K (eq. 24), H_m, ±5 % on a5..a0. The reference finds
// stability from numpy roots of the degree-12 characteristic polynomial
// (coefficients to 1e42), and the norms from 20k-point grids refined by an
// optimiser. Tolerances: the number of unstable members exactly; the worst
// stability measure 1e-6 relative (it is a clearly unstable member, far from
// the boundary); ||H_m T_i|| 1e-5 relative (grid + optimiser vs certified
// 2e-6); coverage 1e-6 relative (both refine the same one-dimensional peak).
// The members are identified by their index (den[1] varying fastest).
TEST(AnalysisRobust, Ahmad2020FamilyMatchesNumpy) {
    std::ifstream f(std::string(PIEZOLOOP_GOLDEN_DIR) + "/analysis_robust.json");
    const nlohmann::json g = nlohmann::json::parse(f);
    const Tf plant{{2.01e11, 4.74e15, 2.76e19, 1.84e23}, {1.0, 1.08e4, 2.95e8, 1.98e12, 1.65e16, 5.79e19, 2.05e23}};
    const Zpk k = tf2zpk(Tf{{5.29e6, 1.78e10, 1.04e15, 7.66e17, 1.51e22, 4.73e22},
                            {1.0, 4.69e5, 3.21e10, 7.86e14, 7.38e18, 4.71e19, 7.79e19}});
    const FamilyResult r = coefficient_family(plant, k, ahmad_hm(), 0.05);
    EXPECT_EQ(r.count, 729);
    EXPECT_EQ(r.unstable, int(g["unstable"]));
    const double sm = g["worst_stability_measure"];
    EXPECT_NEAR(r.worst_stability.stability_measure, sm, 1e-6 * std::abs(sm));
    EXPECT_EQ(r.worst_stability.scale, scale_of(g["worst_stability_index"], 6, 0.05));
    const double h = g["worst_hinf_HmT"];
    EXPECT_NEAR(r.worst_hinf_HmT.hinf_HmT, h, 1e-5 * h);
    EXPECT_EQ(r.worst_hinf_HmT.scale, scale_of(g["worst_hinf_HmT_index"], 6, 0.05));
    const double c = g["worst_coverage"];
    EXPECT_NEAR(r.worst_coverage.coverage, c, 1e-6 * c);
    EXPECT_EQ(r.worst_coverage.scale, scale_of(g["worst_coverage_index"], 6, 0.05));
}
