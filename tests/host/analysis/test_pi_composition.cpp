// PI composition (pi_composition.hpp): exact inverse gives the identity;
// for a perturbed estimate, the composed operator is checked by simulation
// (seeded random inputs, play operators in double written out here) against
// the chain P[P̂⁻¹[v]], and the bound |y − ρ v| <= Σ|p_ηj| r_ηj is checked
// on the same runs.
#include <cmath>
#include <random>
#include <vector>

#include <gtest/gtest.h>

#include "analysis/pi_composition.hpp"
#include "piezoloop/pi_inverse.hpp"

using namespace piezoloop;
using namespace piezoloop::design;

namespace {

// Janaideh2016 §IV-C numerical example: p0 = 0.1 on threshold 0, then 10 operators
// on 4, 8, …, 40.
PiModel numerical_example(double weight_scale = 1.0) {
    const float r[] = {0, 4, 8, 12, 16, 20, 24, 28, 32, 36, 40};
    float p[] = {0.1f, 0.0461f, 0.069f, 0.1029f, 0.1535f, 0.2291f, 0.3417f, 0.5098f, 0.7605f, 1.1345f, 1.6925f};
    for (int i = 1; i < 11; ++i) p[i] = static_cast<float>(p[i] * weight_scale);
    PiModel m;
    EXPECT_TRUE(pi_model_from_lists(r, p, 11, nullptr, m).ok());
    return m;
}

// Janaideh2016's 15-operator set (negative weights, monotone curve).
PiModel set15(double weight_scale = 1.0) {
    const float r[] = {0.095f, 0.38f, 0.84f, 1.46f, 2.21f, 3.07f, 4.01f, 4.98f,
                       5.96f, 6.89f, 7.76f, 8.52f, 9.14f, 9.61f, 9.9f};
    float p[] = {2.55f, 0.57f, 1.3f, -1.57f, 1.25f, -0.054f, -0.032f, 0.66f, 0.16f, -0.77f, 2.02f, -1.63f, -0.15f, 2.99f, -1.09f};
    for (float& x : p) x = static_cast<float>(x * weight_scale);
    PiModel m;
    EXPECT_TRUE(pi_model_from_lists(r, p, 15, nullptr, m).ok());
    return m;
}

// A PI operator in double: y = p0 v + Σ p_j F_{r_j}[v], plays from rest.
struct PiSim {
    double p0;
    std::vector<double> r, p, w;
    double step(double v) {
        double y = p0 * v;
        for (std::size_t j = 0; j < r.size(); ++j) {
            w[j] = std::max(v - r[j], std::min(v + r[j], w[j]));
            y += p[j] * w[j];
        }
        return y;
    }
};

PiSim sim_of(const PiModel& m) {
    PiSim s{m.p0, {}, {}, {}};
    for (int j = 0; j < m.count; ++j) {
        s.r.push_back(m.thresholds[static_cast<std::size_t>(j)]);
        s.p.push_back(m.weights[static_cast<std::size_t>(j)]);
    }
    s.w.assign(s.r.size(), 0.0);
    return s;
}

PiSim sim_of(const PiComposition& c) {
    PiSim s{c.p0, c.thresholds, c.weights, {}};
    s.w.assign(s.r.size(), 0.0);
    return s;
}

// Seeded random walk with reversals, within ±amplitude.
std::vector<double> input(double amplitude, int n, unsigned seed) {
    std::mt19937 rng(seed);
    std::uniform_real_distribution<double> u(-1.0, 1.0);
    std::vector<double> v;
    double x = 0.0, dir = 1.0;
    for (int i = 0; i < n; ++i) {
        if (u(rng) > 0.97) dir = -dir;
        x += dir * amplitude * 0.01 * (1.0 + u(rng));
        x = std::clamp(x, -amplitude, amplitude);
        if (std::abs(x) == amplitude) dir = -dir;
        v.push_back(x);
    }
    return v;
}

}  // namespace

// P̂ = P: η is the identity (ρ = 1, no operators, bound 0). The inverse is
// held in float, so the slopes are 1 to ~1e-6 relative.
TEST(AnalysisPiComposition, ExactInverseIsIdentity) {
    for (const PiModel& p : {numerical_example(), set15()}) {
        PiModel inv;
        ASSERT_TRUE(invert_pi(p, inv).ok());
        const PiComposition c = compose_pi(p, inv);
        EXPECT_NEAR(c.p0, 1.0, 1e-5);
        EXPECT_NEAR(c.rho, 1.0, 1e-5);
        EXPECT_TRUE(c.monotone);
        double sum_abs = 0.0;
        for (double w : c.weights) sum_abs += std::abs(w);
        EXPECT_LT(sum_abs, 1e-4);
        EXPECT_LT(c.xi_bound, 1e-3 * c.curve_v.back());
    }
}

// P̂ with the play weights 5 % low (or high): the chain P[P̂⁻¹[v]] equals the
// PI operator of η step by step (the composition theorem), and |y − ρ v|
// never exceeds the bound. Tolerance 1e-5 of the output range: P and P̂ share
// their thresholds, so ψ̂ reaches φ's thresholds exactly at its own
// (float-rounded, 6e-8) thresholds; compose_pi merges such breakpoints
// (within 1e-6 of the largest), which moves η's corners by that much.
TEST(AnalysisPiComposition, ComposedOperatorMatchesTheChain) {
    struct Case {
        PiModel plant, estimate;
        double amplitude;
    };
    const Case cases[] = {
        {numerical_example(), numerical_example(0.95), 60.0},
        {numerical_example(), numerical_example(1.05), 60.0},
        {set15(), set15(0.9), 40.0},
    };
    unsigned seed = 7;
    for (const Case& k : cases) {
        PiModel inv;
        ASSERT_TRUE(invert_pi(k.estimate, inv).ok());
        const PiComposition c = compose_pi(k.plant, inv);
        ASSERT_TRUE(c.monotone);
        EXPECT_GT(c.xi_bound, 0.0);
        PiSim a = sim_of(inv), b = sim_of(k.plant), comp = sim_of(c);
        double scale = 0.0, worst = 0.0, excess = 0.0;
        for (double v : input(k.amplitude, 20000, seed++)) {
            const double y = b.step(a.step(v));
            const double yc = comp.step(v);
            scale = std::max(scale, std::abs(y));
            worst = std::max(worst, std::abs(y - yc));
            excess = std::max(excess, std::abs(y - c.rho * v) - c.xi_bound);
        }
        EXPECT_LT(worst, 1e-5 * scale);
        EXPECT_LT(excess, 1e-5 * scale);
    }
}

// With an input amplitude V the operators at r >= V never move: ρ and the
// bound only count those below V, and the bound still holds for |v| <= V.
TEST(AnalysisPiComposition, AmplitudeLimitDropsIdleOperators) {
    PiModel inv;
    ASSERT_TRUE(invert_pi(numerical_example(0.95), inv).ok());
    const double v_max = 20.0;
    const PiComposition all = compose_pi(numerical_example(), inv);
    const PiComposition c = compose_pi(numerical_example(), inv, v_max);
    EXPECT_LT(c.weights.size(), all.weights.size());
    for (double r : c.thresholds) EXPECT_LT(r, v_max);
    EXPECT_LT(c.xi_bound, all.xi_bound);
    PiSim a = sim_of(inv), b = sim_of(numerical_example());
    double excess = 0.0;
    for (double v : input(v_max, 20000, 99)) excess = std::max(excess, std::abs(b.step(a.step(v)) - c.rho * v) - c.xi_bound);
    EXPECT_LT(excess, 1e-5 * v_max);  // as above
}

TEST(AnalysisPiComposition, RejectsNonPlainModels) {
    PiModel p = numerical_example();
    PiModel g = p;
    g.input_gain = 2.0f;
    EXPECT_THROW(compose_pi(p, g), std::invalid_argument);
    PiModel bad = p;
    bad.thresholds[1] = bad.thresholds[0];
    EXPECT_THROW(compose_pi(bad, p), std::invalid_argument);
    EXPECT_THROW(compose_pi(p, p, -1.0), std::invalid_argument);
}
