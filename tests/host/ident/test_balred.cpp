// Balanced truncation and Hankel singular values (host/ident/balred.hpp).
// References: scipy's Lyapunov solvers and a numpy square-root balanced
// truncation (tools/ref/ident_balred.py) on Janaideh2016's D(s) and a
// random 9th-order model (continuous and ZOH-discretised); the Kronecker
// form of the Lyapunov equations; and the a-priori bound
// ||G - G_N||_inf <= 2 sum_{i>N} sigma_i checked on a dense frequency grid.
#include <gtest/gtest.h>

#include <cmath>
#include <complex>
#include <fstream>
#include <nlohmann/json.hpp>
#include <random>
#include <stdexcept>
#include <string>
#include <vector>

#include <unsupported/Eigen/KroneckerProduct>

#include "ident/balred.hpp"
#include "test_support.hpp"

using namespace piezoloop::design;
using piezoloop::test::error_of;

namespace {

const nlohmann::json& golden() {
    static const nlohmann::json g = piezoloop::test::load_golden("ident_balred");
    return g;
}

Ss model_of(const nlohmann::json& c) {
    const auto& a = c["A"];
    const int n = static_cast<int>(a.size());
    Ss s;
    s.A.resize(n, n);
    s.B.resize(n);
    s.C.resize(n);
    for (int i = 0; i < n; ++i) {
        for (int j = 0; j < n; ++j) s.A(i, j) = a[i][j];
        s.B(i) = c["B"][i];
        s.C(i) = c["C"][i];
    }
    s.D = c["D"];
    s.ts = c["ts"];
    return s;
}

// G at the complex point p (s = j w, or z = e^{j w ts}).
cplx response(const Ss& s, cplx p) {
    const int n = static_cast<int>(s.A.rows());
    const Eigen::MatrixXcd m = p * Eigen::MatrixXcd::Identity(n, n) - s.A.cast<cplx>();
    const Eigen::VectorXcd x = m.partialPivLu().solve(s.B.cast<cplx>());
    return (s.C.cast<cplx>() * x)(0) + s.D;
}

cplx point(const Ss& s, double w) { return s.ts > 0 ? std::exp(cplx(0, w * s.ts)) : cplx(0, w); }

TEST(IdentBalred, LyapunovSolversMatchTheKroneckerForm) {
    // vec(A X + X A') = (I (x) A + A (x) I) vec X; discrete: (A (x) A - I).
    std::mt19937_64 rng(8);
    std::normal_distribution<double> g(0.0, 1.0);
    const int n = 6;
    Eigen::MatrixXd a(n, n), q0(n, n);
    for (int i = 0; i < n; ++i)
        for (int j = 0; j < n; ++j) {
            a(i, j) = g(rng);
            q0(i, j) = g(rng);
        }
    const Eigen::MatrixXd q = q0 * q0.transpose();
    const Eigen::MatrixXd id = Eigen::MatrixXd::Identity(n, n);
    // Shift A to be stable (continuous) and scale it to be Schur stable.
    const double shift = Eigen::EigenSolver<Eigen::MatrixXd>(a).eigenvalues().real().maxCoeff() + 0.5;
    const Eigen::MatrixXd ac = a - shift * id;
    const double rad = Eigen::EigenSolver<Eigen::MatrixXd>(a).eigenvalues().cwiseAbs().maxCoeff();
    const Eigen::MatrixXd ad = a * (0.9 / rad);
    const Eigen::VectorXd vq = Eigen::Map<const Eigen::VectorXd>(q.data(), n * n);

    const Eigen::MatrixXd kc = Eigen::kroneckerProduct(id, ac) + Eigen::kroneckerProduct(ac, id);
    const Eigen::VectorXd xc = kc.fullPivLu().solve(-vq);
    const Eigen::MatrixXd xcm = Eigen::Map<const Eigen::MatrixXd>(xc.data(), n, n);
    const Eigen::MatrixXd kd = Eigen::kroneckerProduct(ad, ad) - Eigen::MatrixXd::Identity(n * n, n * n);
    const Eigen::VectorXd xd = kd.fullPivLu().solve(-vq);
    const Eigen::MatrixXd xdm = Eigen::Map<const Eigen::MatrixXd>(xd.data(), n, n);

    // Two backward-stable solvers of small, moderately conditioned
    // equations: agreement to ~1e-13 relative; 1e-10 leaves margin.
    EXPECT_LT((solve_lyapunov_continuous(ac, q) - xcm).norm(), 1e-10 * xcm.norm());
    EXPECT_LT((solve_lyapunov_discrete(ad, q) - xdm).norm(), 1e-10 * xdm.norm());
}

class IdentBalredCase : public ::testing::TestWithParam<int> {};

TEST_P(IdentBalredCase, HankelSingularValuesMatchScipy) {
    const auto& c = golden()["cases"][GetParam()];
    const Ss sys = model_of(c);
    const std::vector<double> hsv = hankel_singular_values(sys);
    const std::vector<double> want = c["hsv"];
    ASSERT_EQ(hsv.size(), want.size());
    // Both compute Gramians of a well-scaled realisation in double; HSVs
    // carry an absolute error of ~eps * cond * sigma_1. The bound
    // 1e-9 sigma_1 + 1e-7 sigma_i holds the smallest ones (1e-6 sigma_1)
    // to ~1e-3 relative and the large ones to 1e-7.
    for (std::size_t i = 0; i < hsv.size(); ++i)
        EXPECT_NEAR(hsv[i], want[i], 1e-9 * want[0] + 1e-7 * want[i]) << c["name"] << " " << i;
}

TEST_P(IdentBalredCase, ReducedModelsMatchNumpyAndRespectTheBound) {
    const auto& c = golden()["cases"][GetParam()];
    const Ss sys = model_of(c);
    const std::vector<double> w = c["omega"];
    for (const auto& red : c["reduced"]) {
        const int order = red["order"];
        const BalancedTruncation bt = balanced_truncation(sys, order);
        ASSERT_EQ(bt.reduced.A.rows(), order);
        EXPECT_EQ(bt.reduced.ts, sys.ts);
        EXPECT_NEAR(bt.error_bound, red["bound"].get<double>(), 1e-9 * bt.hsv[0]) << c["name"];
        // Transfer functions (coordinate free) against numpy's truncation:
        // the reduced model depends smoothly on the Gramians, so the
        // agreement follows the HSV agreement; 1e-6 of |G| plus 1e-9 of sigma_1.
        for (std::size_t k = 0; k < w.size(); ++k) {
            const cplx g = response(bt.reduced, point(sys, w[k]));
            const cplx want(red["re"][k].get<double>(), red["im"][k].get<double>());
            EXPECT_LT(std::abs(g - want), 1e-6 * std::abs(want) + 1e-9 * bt.hsv[0]) << c["name"] << " " << k;
        }
        // Stable; and for continuous models balanced: both Gramians of the
        // truncation are diag(sigma_1..sigma_N) (1e-8 of sigma_1: rounding
        // of the solves). A truncated discrete balanced model is stable but
        // not balanced in general, so that part is continuous only.
        const Eigen::VectorXcd poles = Eigen::EigenSolver<Eigen::MatrixXd>(bt.reduced.A).eigenvalues();
        for (int i = 0; i < order; ++i)
            EXPECT_TRUE(sys.ts > 0 ? std::abs(poles(i)) < 1.0 : poles(i).real() < 0.0) << c["name"];
        if (sys.ts == 0) {
            const Eigen::MatrixXd bb = bt.reduced.B * bt.reduced.B.transpose();
            const Eigen::MatrixXd cc = bt.reduced.C.transpose() * bt.reduced.C;
            const Eigen::MatrixXd p = solve_lyapunov_continuous(bt.reduced.A, bb);
            const Eigen::MatrixXd q = solve_lyapunov_continuous(bt.reduced.A.transpose(), cc);
            const Eigen::VectorXd s = Eigen::Map<const Eigen::VectorXd>(bt.hsv.data(), order);
            EXPECT_LT((p - Eigen::MatrixXd(s.asDiagonal())).norm(), 1e-8 * bt.hsv[0]) << c["name"];
            EXPECT_LT((q - Eigen::MatrixXd(s.asDiagonal())).norm(), 1e-8 * bt.hsv[0]) << c["name"];
        }

        // Error bound on a dense grid (a lower estimate of the H-inf norm,
        // so the bound must hold at every point; 1e-9 relative slack for
        // rounding). Continuous: 20000 log-spaced points from 1e-3 x the
        // slowest to 1e3 x the fastest pole, plus w = 0; discrete: 20000
        // points over [0, pi/ts].
        const Eigen::VectorXcd fp = Eigen::EigenSolver<Eigen::MatrixXd>(sys.A).eigenvalues();
        std::vector<double> grid;
        const int m = 20000;
        if (sys.ts > 0) {
            for (int k = 0; k <= m; ++k) grid.push_back(M_PI / sys.ts * k / m);
        } else {
            const double lo = 1e-3 * fp.cwiseAbs().minCoeff(), hi = 1e3 * fp.cwiseAbs().maxCoeff();
            grid.push_back(0.0);
            for (int k = 0; k <= m; ++k) grid.push_back(lo * std::pow(hi / lo, double(k) / m));
        }
        double peak = 0.0;
        for (double wk : grid) {
            const cplx p0 = point(sys, wk);
            peak = std::max(peak, std::abs(response(sys, p0) - response(bt.reduced, p0)));
        }
        EXPECT_LE(peak, bt.error_bound * (1 + 1e-9)) << c["name"] << " order " << order;
        // And no order-N model can do better than sigma_{N+1} (Hankel-norm
        // lower bound); the grid may miss the exact peak, so 0.99 of it.
        EXPECT_GE(peak, 0.99 * bt.hsv[order]) << c["name"] << " order " << order;
    }
}

INSTANTIATE_TEST_SUITE_P(Fixtures, IdentBalredCase, ::testing::Values(0, 1, 2));

TEST(IdentBalred, FullOrderIsTheSameSystemWithZeroBound) {
    const Ss sys = model_of(golden()["cases"][1]);
    const BalancedTruncation bt = balanced_truncation(sys, 9);
    EXPECT_EQ(bt.error_bound, 0.0);
    for (double w : {0.1, 3.0, 100.0, 5000.0}) {
        const cplx g = response(sys, cplx(0, w));
        // A similarity transform: rounding of the balancing transformation.
        EXPECT_LT(std::abs(response(bt.reduced, cplx(0, w)) - g), 1e-8 * (std::abs(g) + 1.0)) << w;
    }
}

TEST(IdentBalred, RefusesModelsItCannotReduce) {
    Ss s;
    s.A = Eigen::MatrixXd::Zero(3, 3);
    s.A.diagonal() << -1.0, -2.0, 0.5;
    s.B = Eigen::VectorXd::Ones(3);
    s.C = Eigen::RowVectorXd::Ones(3);
    const std::string unstable = error_of([&] { balanced_truncation(s, 1); });
    EXPECT_EQ(unstable.rfind("model: not stable (pole 0.5 + 0j, Re >= 0)", 0), 0u) << unstable;
    s.ts = 0.1;
    s.A.diagonal() << 0.5, -0.2, 1.0;
    EXPECT_NE(error_of([&] { hankel_singular_values(s); }).find("|z| >= 1"), std::string::npos);
    s.ts = 0.0;
    s.A.diagonal() << -1.0, -2.0, -3.0;
    EXPECT_EQ(error_of([&] { balanced_truncation(s, 0); }), "order: must be in [1, 3] (the model's state count)");
    EXPECT_EQ(error_of([&] { balanced_truncation(s, 4); }), "order: must be in [1, 3] (the model's state count)");
    // The third state is uncontrollable: only two Hankel singular values.
    s.B(2) = 0.0;
    const std::string nonmin = error_of([&] { balanced_truncation(s, 3); });
    EXPECT_EQ(nonmin.rfind("order: Hankel singular value 3", 0), 0u) << nonmin;
    EXPECT_NE(nonmin.find("choose order <= 2"), std::string::npos) << nonmin;
    EXPECT_NO_THROW(balanced_truncation(s, 2));
    s.B = Eigen::VectorXd::Ones(2);
    EXPECT_EQ(error_of([&] { balanced_truncation(s, 1); }), "B: must have as many rows as A");
    s.B = Eigen::VectorXd::Ones(3);
    s.A(0, 1) = std::nan("");
    EXPECT_EQ(error_of([&] { balanced_truncation(s, 1); }), "A: contains NaN/Inf");
    s.A(0, 1) = 0.0;
    s.D = INFINITY;
    EXPECT_EQ(error_of([&] { balanced_truncation(s, 1); }), "D: is NaN/Inf");
    EXPECT_EQ(error_of([&] { hankel_singular_values(Ss{}); }), "A: the model has no states");
}

}  // namespace
