// The damping mixed-sensitivity design (host/synth/damping_mixsyn):
//  * the augmented plant closed with a given K equals, line by line, the
//    2 x 2 map [W1 S, -W1 S G Wd; W2 K S, -W2 T Wd] computed from the
//    models' own responses (an analytic reference, independent of the
//    state-space construction);
//  * on a lightly damped mode the plain S / KS design (synth/mixsyn) leaves
//    the mode at its open-loop damping (its zeros cancel the pair), and the
//    damping design moves it: the closed-loop poles, the roots of the
//    characteristic polynomial den_G den_K + num_G num_K (polynomial
//    algebra), are also eigenvalues of the synthesis' closed loop (state
//    space), and the pair near the mode has ζ well above the plant's;
//  * bad weights are refused naming them.
#include <algorithm>
#include <cmath>
#include <cstdio>
#include <complex>
#include <numbers>
#include <stdexcept>
#include <vector>

#include <gtest/gtest.h>

#include <Eigen/Dense>

#include "lti/freqresp.hpp"
#include "lti/lti_convert.hpp"
#include "synth/damping_mixsyn.hpp"
#include "synth/mixsyn.hpp"

using namespace piezoloop::design;

namespace {

constexpr double kTwoPi = 2.0 * std::numbers::pi;

// A unit-DC-gain mode at f_Hz with damping zeta, behind a first-order lag
// at lag_Hz (a sensor's bandwidth).
Zpk mode_plant(double f_Hz, double zeta, double lag_Hz) {
    const double w = kTwoPi * f_Hz, wl = kTwoPi * lag_Hz;
    const cplx p(-zeta * w, w * std::sqrt(1.0 - zeta * zeta));
    return Zpk{{}, {p, std::conj(p), cplx(-wl)}, w * w * wl, 0.0};
}

// The commissioning's weights at the target bandwidth f_Hz.
Zpk w1_at(double f_Hz) {
    const double wb = kTwoPi * f_Hz;
    return Zpk{{cplx(-1.6 * wb)}, {cplx(-1e-3 * wb)}, 1.0 / 1.6, 0.0};
}
const Zpk kW2{{}, {}, 0.5, 0.0};
const Zpk kWd{{}, {}, 1.0, 0.0};

// P(jw) of the generalised plant, a 3 x 3 complex matrix.
Eigen::MatrixXcd response(const GeneralisedPlant& p, double w) {
    const auto& s = p.sys;
    const Eigen::Index n = s.A.rows();
    const Eigen::MatrixXcd jw = cplx(0.0, w) * Eigen::MatrixXcd::Identity(n, n);
    const Eigen::MatrixXcd x = (jw - s.A.cast<cplx>()).partialPivLu().solve(s.B.cast<cplx>());
    return s.C.cast<cplx>() * x + s.D.cast<cplx>();
}

// The closed-loop poles from polynomial algebra: roots of den_G den_K +
// num_G num_K.
std::vector<cplx> characteristic_roots(const Zpk& g, const Zpk& k) {
    std::vector<double> a = poly_mul(poly_from_roots(g.poles), poly_from_roots(k.poles));
    std::vector<double> b = poly_mul(poly_from_roots(g.zeros), poly_from_roots(k.zeros));
    for (double& c : b) c *= g.gain * k.gain;
    std::vector<double> sum(std::max(a.size(), b.size()), 0.0);  // highest power first
    for (std::size_t i = 0; i < a.size(); ++i) sum[sum.size() - a.size() + i] += a[i];
    for (std::size_t i = 0; i < b.size(); ++i) sum[sum.size() - b.size() + i] += b[i];
    return poly_roots(sum);
}

// The damping of the closed-loop pole nearest the mode at w (rad/s).
double damping_near(const std::vector<cplx>& poles, double w) {
    const cplx* best = nullptr;
    for (const cplx& p : poles)
        if (p.imag() > 0.0 && (!best || std::abs(std::abs(p) - w) < std::abs(std::abs(*best) - w))) best = &p;
    return best ? -best->real() / std::abs(*best) : -1.0;
}

}  // namespace

// Each entry of the closed loop within 1e-9 of the models' own responses
// (relative to the entry's size plus 1e-12): two evaluations of the same
// rational functions, differing only by rounding.
TEST(DampingMixsyn, AugmentedPlantIsTheFourBlockMap) {
    const Zpk g = mode_plant(500.0, 0.01, 5000.0);
    const Zpk w1 = w1_at(100.0);
    const Zpk wd{{cplx(-300.0)}, {cplx(-3000.0)}, 2.0, 0.0};  // not a constant: its states are in the plant
    const GeneralisedPlant p = augment_input_disturbance(g, w1, kW2, wd);
    ASSERT_EQ(p.n_w, 2);
    ASSERT_EQ(p.n_u, 1);
    ASSERT_EQ(p.n_z, 2);
    ASSERT_EQ(p.n_y, 1);
    const Zpk k{{cplx(-200.0)}, {cplx(-0.1)}, 300.0, 0.0};  // a PI, any K will do
    for (const double f : {1.0, 37.0, 490.0, 500.0, 2200.0, 4e4}) {
        const double w = kTwoPi * f;
        const cplx s(0.0, w);
        const cplx G = evaluate(g, s), K = evaluate(k, s), W1 = evaluate(w1, s), W2 = evaluate(kW2, s),
                   Wd = evaluate(wd, s);
        const cplx S = 1.0 / (1.0 + G * K), T = G * K * S;
        const cplx want[2][2] = {{W1 * S, -W1 * S * G * Wd}, {W2 * K * S, -W2 * T * Wd}};
        // The lower fractional transformation with u = K e, line by line.
        const Eigen::MatrixXcd P = response(p, w);
        const cplx P22 = P(2, 2);
        for (int i = 0; i < 2; ++i)
            for (int j = 0; j < 2; ++j) {
                const cplx got = P(i, j) + P(i, 2) * K / (1.0 - P22 * K) * P(2, j);
                EXPECT_NEAR(std::abs(got - want[i][j]), 0.0, 1e-9 * std::abs(want[i][j]) + 1e-12)
                    << "entry " << i << "," << j << " at " << f << " Hz";
            }
    }
}

// A 500 Hz mode at ζ 0.005 behind a 5 kHz lag, the loop at 100 Hz. The plain
// design leaves the pair within 0.002 of ζ 0.005 (it cancels it); the
// damping design brings it above 0.05, ten times the plant's, with the
// loop stable. Poles agree between the two computations to 1e-6 of their
// size (roots of a degree-12 polynomial with well separated roots).
TEST(DampingMixsyn, DampsTheModeThePlainDesignCancels) {
    const double f_mode = 500.0, zeta = 0.005;
    const Zpk g = mode_plant(f_mode, zeta, 5000.0);
    const Zpk w1 = w1_at(100.0);
    HinfOptions o;
    o.rel_tol = 1e-4;
    const MixsynResult plain = mixsyn(g, w1, kW2, std::nullopt, o);
    const DampingMixsynResult damped = damping_mixsyn(g, w1, kW2, kWd, o);
    ASSERT_TRUE(plain.stable);
    ASSERT_TRUE(damped.stable);
    const double w = kTwoPi * f_mode;
    const std::vector<cplx> plain_poles = characteristic_roots(g, plain.controller_zpk);
    const std::vector<cplx> damped_poles = characteristic_roots(g, damped.controller_zpk);
    std::printf("mode's closed-loop damping: plain design %.4f, damping design %.4f (plant %.4f)\n",
                damping_near(plain_poles, w), damping_near(damped_poles, w), zeta);
    EXPECT_NEAR(damping_near(plain_poles, w), zeta, 0.002) << "the plain design cancels the mode";
    EXPECT_GT(damping_near(damped_poles, w), 0.05) << "the damping design damps it";
    for (const cplx& p : damped_poles) EXPECT_LT(p.real(), 0.0) << "closed-loop pole " << p;
    // The same poles as eigenvalues of the synthesis' closed loop (which also
    // holds the weights' states).
    const Eigen::VectorXcd eig = damped.synthesis.closed_loop.A.eigenvalues();
    for (const cplx& p : damped_poles) {
        double nearest = INFINITY;
        for (Eigen::Index i = 0; i < eig.size(); ++i) nearest = std::min(nearest, std::abs(eig(i) - p));
        EXPECT_LT(nearest, 1e-6 * std::abs(p)) << "pole " << p;
    }
}

TEST(DampingMixsyn, RefusesBadWeightsNamingThem) {
    const Zpk g = mode_plant(500.0, 0.01, 5000.0);
    const Zpk unstable{{}, {cplx(3.0)}, 1.0, 0.0};
    const Zpk improper{{cplx(-1.0), cplx(-2.0)}, {cplx(-3.0)}, 1.0, 0.0};
    auto message = [&](const Zpk& w1, const Zpk& w2, const Zpk& wd) {
        try {
            augment_input_disturbance(g, w1, w2, wd);
        } catch (const std::invalid_argument& e) {
            return std::string(e.what());
        }
        return std::string("accepted");
    };
    EXPECT_EQ(message(w1_at(100.0), kW2, unstable).rfind("wd: weight is unstable", 0), 0u);
    EXPECT_EQ(message(w1_at(100.0), improper, kWd).rfind("w2: weight is improper", 0), 0u);
    EXPECT_EQ(message(unstable, kW2, kWd).rfind("w1: weight is unstable", 0), 0u);
}
