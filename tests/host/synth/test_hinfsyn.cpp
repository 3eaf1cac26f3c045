// H∞ output-feedback synthesis (host/synth/hinfsyn): an analytic optimum,
// the loop-shifting and D11 paths, the named failures, and the closed-loop
// norm of every returned controller recomputed with the analysis code.
#include <cmath>
#include <string>

#include <gtest/gtest.h>

#include "analysis/hinf.hpp"
#include "synth/hinfsyn.hpp"
#include "synth/mimo_hinf.hpp"

using namespace piezoloop::design;

namespace {

// First-order problem with a closed-form optimum (the rate of the example
// in Doyle, Glover, Khargonekar & Francis 1989, worked out here):
//   x' = w1 + u,  z = [x; u],  y = x + w2      (A = 0, all gains 1).
// With D12 = [0; 1], D21 = [0 1], D11 = 0 (the normal form already):
//   X∞: 2·0·X - X²(B2² - B1²/γ²) + C1² = 0  =>  X = 1 / sqrt(1 - γ^-2)
//       (stabilising: A - (1 - γ^-2) X < 0 needs γ > 1),
//   Y∞: the dual, the same numbers: Y = 1 / sqrt(1 - γ^-2),
//   ρ(XY) < γ²  <=>  1 / (1 - γ^-2) < γ²  <=>  γ² - 1 > 1  <=>  γ > √2.
// So γ_opt = √2: the coupling condition binds, not the Riccati equations.
GeneralisedPlant first_order(double d22 = 0.0) {
    GeneralisedPlant p;
    p.n_w = 2;
    p.n_u = 1;
    p.n_z = 2;
    p.n_y = 1;
    p.sys.A = Eigen::MatrixXd::Zero(1, 1);
    p.sys.B.resize(1, 3);
    p.sys.B << 1, 0, 1;
    p.sys.C.resize(3, 1);
    p.sys.C << 1, 0, 1;
    p.sys.D.resize(3, 3);
    p.sys.D << 0, 0, 0,  //
        0, 0, 1,         //
        0, 1, d22;
    return p;
}

// Every channel of the closed loop recomputed with analysis/hinf.hpp (the
// project's certified SISO norm) must stay below γ_K: each channel's norm
// is a lower bound of the MIMO norm. 1e-6 relative: the SISO norm's
// accuracy (1e-7) and rounding in the closed loop.
void expect_channels_below(const HinfSynthesis& r) {
    ASSERT_TRUE(r.stable);
    for (Eigen::Index i = 0; i < r.closed_loop.outputs(); ++i)
        for (Eigen::Index j = 0; j < r.closed_loop.inputs(); ++j) {
            const HinfResult h = hinf_norm(to_siso(r.closed_loop, i, j));
            EXPECT_LE(h.norm, r.gamma_controller * (1 + 1e-6)) << "channel " << i << "," << j;
        }
    EXPECT_LE(r.gamma, r.gamma_controller * (1 + 1e-6));
}

std::string error_of(const GeneralisedPlant& p, const HinfOptions& o = {}) {
    try {
        hinfsyn(p, o);
    } catch (const std::exception& e) {
        return e.what();
    }
    return "";
}

}  // namespace

// γ_opt = √2 within the bisection's tolerance (1e-6, the default), and the
// controller at γ_K = 1.001 γ_opt achieves at most γ_K.
TEST(Hinfsyn, FirstOrderAnalyticOptimum) {
    const HinfSynthesis r = hinfsyn(first_order());
    EXPECT_NEAR(r.gamma_opt, std::sqrt(2.0), 2e-6 * std::sqrt(2.0));
    EXPECT_LE(r.gamma_lower, std::sqrt(2.0) * (1 + 1e-9));
    expect_channels_below(r);
    EXPECT_GE(r.gamma, std::sqrt(2.0) * (1 - 1e-6));  // no controller beats the optimum
}

// D22 ≠ 0 (loop shifting): y - D22 u is available to the controller, so the
// optimum is the same √2.
TEST(Hinfsyn, LoopShiftingKeepsOptimum) {
    const HinfSynthesis r = hinfsyn(first_order(0.7));
    EXPECT_NEAR(r.gamma_opt, std::sqrt(2.0), 2e-6 * std::sqrt(2.0));
    expect_channels_below(r);
}

// Scaling of D12 and D21 (non-identity, non-square) leaves γ_opt unchanged
// when it is a change of variables of u and y only: u = 2 u', y = 3 y'.
TEST(Hinfsyn, D12D21Scaling) {
    GeneralisedPlant p = first_order();
    p.sys.B.col(2) *= 0.5;      // u' = 2 u: B2 and D12 halve ...
    p.sys.D.col(2) *= 0.5;
    p.sys.C.row(2) *= 3.0;      // y' = 3 y: C2 and D21 triple
    p.sys.D.row(2) *= 3.0;
    const HinfSynthesis r = hinfsyn(p);
    EXPECT_NEAR(r.gamma_opt, std::sqrt(2.0), 2e-6 * std::sqrt(2.0));
    expect_channels_below(r);
}

// D11 ≠ 0 handled by the general formulas: γ_opt is at least the D11 bound
// and the achieved norm is within γ_K.
TEST(Hinfsyn, GeneralD11) {
    GeneralisedPlant p = first_order();
    p.sys.D(0, 0) = 0.8;  // z1 = x + 0.8 w1: D1111 = 0.8
    p.sys.D(1, 1) = 0.3;  // z2 = u + 0.3 w2: D1122
    const HinfSynthesis r = hinfsyn(p);
    EXPECT_GT(r.gamma_opt, 0.8);
    expect_channels_below(r);
    EXPECT_GE(r.gamma, r.gamma_opt * (1 - 1e-5));
}

// Optimum γ = 0: the SISO example of Octave's and python-control's hinfsyn
// tests, x' = -x + w + u, z = x + u, y = x + w. With D12 = D21 = 1 both
// Riccati equations have Q = 0 and stable A - B2 C1, A - B1 C2, so X∞ =
// Y∞ = 0 at every γ > 0 and the central controller is A - B2 C1 - B1 C2,
// B1, -C1: K = -1/(s + 3). Worked out by hand: with the controller state ξ,
// z = x - ξ and (x - ξ)' = -2 (x - ξ), so from rest z is identically zero
// (the published optimum). And a fresh one: x' = -2x + w + 3u,
// z = 0.5x + u, y = x + w: K = -0.5/(s + 4.5), (x - ξ)' = -3 (x - ξ).
// The search ends at its floor (1e-12 of the first feasible γ, 1) with
// gamma_lower 0; the achieved norm is rounding: below 1e-12 (it is ~3e-16).
// The controller's coefficients to 1e-9 (exact in exact arithmetic; the
// normalisation's powers of two are exact too).
GeneralisedPlant zero_optimum(double a, double b2, double c1) {
    GeneralisedPlant p;
    p.n_w = p.n_u = p.n_z = p.n_y = 1;
    p.sys.A = Eigen::MatrixXd::Constant(1, 1, a);
    p.sys.B.resize(1, 2);
    p.sys.B << 1, b2;
    p.sys.C.resize(2, 1);
    p.sys.C << c1, 1;
    p.sys.D.resize(2, 2);
    p.sys.D << 0, 1,  //
        1, 0;
    return p;
}

TEST(Hinfsyn, ZeroOptimumFound) {
    struct Case {
        double a, b2, c1;
        double k_pole, k_gain;  // K = k_gain / (s - k_pole)
    };
    for (const Case& c : {Case{-1.0, 1.0, 1.0, -3.0, -1.0}, Case{-2.0, 3.0, 0.5, -4.5, -0.5}}) {
        const HinfSynthesis r = hinfsyn(zero_optimum(c.a, c.b2, c.c1));
        ASSERT_TRUE(r.stable);
        EXPECT_EQ(r.gamma_lower, 0.0);
        EXPECT_LE(r.gamma_opt, 1e-12 * (1 + 1e-9));  // twelve divisions by 10 of 1
        EXPECT_LE(r.gamma, 1e-12);
        const HinfResult h = hinf_norm(to_siso(r.closed_loop, 0, 0));
        EXPECT_LE(h.norm, 1e-12);
        ASSERT_EQ(r.controller.A.rows(), 1);
        EXPECT_NEAR(r.controller.A(0, 0), c.k_pole, 1e-9 * std::fabs(c.k_pole));
        EXPECT_NEAR(r.controller.B(0, 0) * r.controller.C(0, 0), c.k_gain, 1e-9 * std::fabs(c.k_gain));
        EXPECT_NEAR(r.controller.D(0, 0), 0.0, 1e-12);
    }
}

TEST(Hinfsyn, NamedFailures) {
    GeneralisedPlant p = first_order();
    p.sys.D(1, 2) = 0.0;  // u no longer reaches z
    EXPECT_NE(error_of(p).find("D12 not of full column rank"), std::string::npos) << error_of(p);

    p = first_order();
    p.sys.D(2, 1) = 0.0;  // no noise on y
    EXPECT_NE(error_of(p).find("D21 not of full row rank"), std::string::npos) << error_of(p);

    // An unstable mode u cannot reach: x2' = x2, seen by y and z.
    p = first_order();
    p.sys.A = Eigen::MatrixXd::Zero(2, 2);
    p.sys.A(1, 1) = 1.0;
    p.sys.B.conservativeResize(2, 3);
    p.sys.B.row(1) << 1, 0, 0;
    p.sys.C.conservativeResize(3, 2);
    p.sys.C.col(1) << 1, 0, 1;
    EXPECT_NE(error_of(p).find("(A, B2) not stabilisable"), std::string::npos) << error_of(p);

    // An interval that ends below √2.
    HinfOptions o;
    o.gamma_max = 1.2;
    const std::string e = error_of(first_order(), o);
    EXPECT_NE(e.find("no γ in the search interval [0, 1.2]"), std::string::npos) << e;

    // A zero of (A, B2, C1, D12) on the axis: x' = u, z = [x - ... ]: an
    // integrator state the cost never sees and that w drives.
    p = first_order();
    p.sys.C(0, 0) = 0.0;  // z = [0; u]: [A - jωI B2; C1 D12] = [[-jω, 1], [0, 0], [0, 1]] at ω = 0
    EXPECT_NE(error_of(p).find("[A - jωI B2; C1 D12] loses rank at ω = 0"), std::string::npos) << error_of(p);

    p = first_order();
    p.n_w = 1;  // sizes disagree
    EXPECT_NE(error_of(p).find("partition says w + u = 2"), std::string::npos) << error_of(p);
}

// The MIMO norm of a known system: G = diag(1/(s+1), 2/(s+3)) has ||G||∞ = 1
// (both at ω = 0, 1 > 2/3); [1/(s+1); 1/(s+1)] has sqrt(2).
TEST(MimoHinf, KnownNorms) {
    StateSpace g;
    g.A = Eigen::MatrixXd::Zero(2, 2);
    g.A.diagonal() << -1, -3;
    g.B = Eigen::MatrixXd::Identity(2, 2);
    g.C = Eigen::MatrixXd::Zero(2, 2);
    g.C.diagonal() << 1, 2;
    g.D = Eigen::MatrixXd::Zero(2, 2);
    EXPECT_NEAR(hinf_norm_mimo(g).norm, 1.0, 1e-9);
    StateSpace c;
    c.A = Eigen::MatrixXd::Constant(1, 1, -1.0);
    c.B = Eigen::MatrixXd::Ones(1, 1);
    c.C = Eigen::MatrixXd::Ones(2, 1);
    c.D = Eigen::MatrixXd::Zero(2, 1);
    EXPECT_NEAR(hinf_norm_mimo(c).norm, std::sqrt(2.0), 1e-9);
}
