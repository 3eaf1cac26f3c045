// PI weight fit (host/ident/pi_fit.hpp). References: numpy lstsq and
// scipy.optimize.nnls on the same data (tools/ref/ident_pi.py), recovery of
// the known weights within their standard errors, Shan2012's grid, and
// refusal of data that cannot separate the operators.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <fstream>
#include <nlohmann/json.hpp>
#include <random>
#include <stdexcept>
#include <string>
#include <vector>

#include "ident/pi_fit.hpp"
#include "test_support.hpp"
#include "piezoloop/pi_inverse.hpp"

using namespace piezoloop;
using namespace piezoloop::design;
using piezoloop::test::error_of;

namespace {

const nlohmann::json& golden() {
    static const nlohmann::json g = piezoloop::test::load_golden("ident_pi");
    return g;
}

// Regressor matrix from the play definition, written out here.
Eigen::MatrixXd regressors(const std::vector<double>& u, const std::vector<double>& r) {
    Eigen::MatrixXd phi(u.size(), r.size() + 1);
    std::vector<double> w(r.size(), 0.0);
    for (std::size_t k = 0; k < u.size(); ++k) {
        phi(k, 0) = u[k];
        for (std::size_t j = 0; j < r.size(); ++j) {
            w[j] = std::max(u[k] - r[j], std::min(u[k] + r[j], w[j]));
            phi(k, j + 1) = w[j];
        }
    }
    return phi;
}

TEST(IdentPi, PlayRegressorIsTheCorePlayOperator) {
    // Same recursion as piezoloop::play from w = 0, in double; compared with
    // the float core on a float-exact input (differences are float rounding).
    const std::vector<double> u = golden()["u"];
    const std::vector<double> w = play_regressor(u, 2.5);
    PlayOperator<float> op(2.5f);
    for (std::size_t k = 0; k < u.size(); ++k)
        ASSERT_NEAR(w[k], op.apply(static_cast<float>(u[k])), 1e-5) << k;  // float rounding of |u| <= 11
}

TEST(IdentPi, Set15WithNegativeWeightsMatchesLstsqAndRecoversTheModel) {
    const auto& g = golden();
    const auto& c = g["set15"];
    const std::vector<double> u = g["u"], y = c["y"], r = c["thresholds"], truth = c["weights"];
    PiFitOptions o;
    o.thresholds = r;
    const PiFitResult res = fit_pi(u, y, o);
    ASSERT_EQ(res.weights.size(), 15u);
    // Same least-squares problem as numpy's lstsq, both in double with a
    // condition number of the normalised regressors ~1e3: agreement to
    // ~1e-12; 1e-9 leaves margin for the 1e-6-rounded data's scale.
    for (int j = 0; j < 15; ++j) EXPECT_NEAR(res.weights[j], c["lstsq"][j].get<double>(), 1e-9) << j;
    // Recovery: within 4 standard errors sigma sqrt(diag((Phi'Phi)^-1)).
    const double sigma = c["noise_sigma"];
    const Eigen::MatrixXd phi = regressors(u, r);
    const Eigen::VectorXd se = sigma * (phi.transpose() * phi).inverse().diagonal().cwiseSqrt();
    int negative = 0;
    for (int j = 0; j < 15; ++j) {
        EXPECT_LE(std::fabs(res.weights[j] - truth[j]), 4 * se(j)) << j;
        if (truth[j] < 0) {
            ++negative;
            EXPECT_LT(res.weights[j], 0.0) << j;
        }
    }
    EXPECT_EQ(negative, 7);
    // PiModel for the core: p0 and 14 operators, float.
    EXPECT_EQ(res.model.count, 14);
    EXPECT_EQ(res.model.p0, static_cast<float>(res.weights[0]));
    EXPECT_EQ(res.model.thresholds[13], static_cast<float>(r[13]));
    EXPECT_EQ(res.model.weights[2], static_cast<float>(res.weights[3]));
    // The published set is invertible (every slope > 0), and so is the fit.
    EXPECT_TRUE(res.invertible) << res.invertibility;
    EXPECT_EQ(res.invertibility, "ok");
    for (double s : res.slopes) EXPECT_GT(s, 0.0);
    // Residual rms = noise sigma (3000 samples: relative spread ~1.3 %; 5 %).
    EXPECT_NEAR(res.rms_error, sigma, 0.05 * sigma);
    EXPECT_GT(res.max_error, res.rms_error);
    EXPECT_LT(res.nrmse_percent, 1.0);
}

TEST(IdentPi, UniformGridUnconstrainedFitOfANonMonotoneModelIsNotInvertible) {
    const auto& g = golden();
    const auto& c = g["nonmonotone"];
    const std::vector<double> u = g["u"], y = c["y"], r = c["thresholds"];
    PiFitOptions o;
    o.operators = c["operators"];
    // Uniform grid: r_j = j * max|u| / (n + 1), as the script computes it
    // (one rounding apart at most).
    const std::vector<double> grid = pi_fit_thresholds(u, o);
    ASSERT_EQ(grid.size(), r.size());
    for (std::size_t j = 0; j < r.size(); ++j) EXPECT_NEAR(grid[j], r[j], 4e-16 * r.back()) << j;
    const PiFitResult res = fit_pi(u, y, o);
    for (int j = 0; j < 9; ++j) EXPECT_NEAR(res.weights[j], c["lstsq"][j].get<double>(), 1e-9) << j;
    // Loading-curve slopes P_0..P_3 = 1, 1.5, 0.7, -0.2: the fourth segment
    // (PiModel weight index 2) makes the model non-invertible.
    EXPECT_LT(res.slopes[3], 0.0);
    EXPECT_FALSE(res.invertible);
    EXPECT_NE(res.invertibility.find("weights[2]"), std::string::npos) << res.invertibility;
}

TEST(IdentPi, MonotoneFitMatchesScipyNnlsAndIsInvertible) {
    const auto& g = golden();
    const auto& c = g["nonmonotone"];
    const std::vector<double> u = g["u"], y = c["y"];
    PiFitOptions o;
    o.operators = c["operators"];
    o.monotone = true;
    o.min_slope = c["min_slope"];
    const PiFitResult res = fit_pi(u, y, o);
    // The constrained optimum is unique (full-rank regressors) and both
    // solvers end with the same active set; the remaining free variables
    // solve the same least-squares problem: agreement to ~1e-12, test 1e-8.
    for (int j = 0; j < 9; ++j) {
        EXPECT_NEAR(res.weights[j], c["monotone"][j].get<double>(), 1e-8) << j;
        EXPECT_NEAR(res.slopes[j], c["monotone_slopes"][j].get<double>(), 1e-8) << j;
        EXPECT_GE(res.slopes[j], o.min_slope * (1 - 1e-12)) << j;
    }
    EXPECT_EQ(res.active_constraints, 1);
    EXPECT_NEAR(res.slopes[3], o.min_slope, 1e-12);  // re-summed from the weights
    EXPECT_EQ(res.min_slope, o.min_slope);
    EXPECT_TRUE(res.invertible) << res.invertibility;
    PiModel inv;
    EXPECT_TRUE(invert_pi(res.model, inv).ok());
    // Negative weights remain allowed: only the slopes are constrained.
    EXPECT_LT(res.weights[2], 0.0);
    // The constraint costs accuracy against the non-monotone truth.
    PiFitOptions free = o;
    free.monotone = false;
    EXPECT_GT(res.rms_error, fit_pi(u, y, free).rms_error);
}

TEST(IdentPi, MonotoneFitOfAMonotoneModelIsTheUnconstrainedFit) {
    // Set15 is invertible (all slopes >= 2.5 - 1.6): no constraint becomes
    // active, so both fits solve the same problem (to the NNLS tolerance).
    const auto& g = golden();
    const std::vector<double> u = g["u"], y = g["set15"]["y"];
    PiFitOptions o;
    o.thresholds = g["set15"]["thresholds"].get<std::vector<double>>();
    const PiFitResult free = fit_pi(u, y, o);
    o.monotone = true;
    const PiFitResult mono = fit_pi(u, y, o);
    EXPECT_EQ(mono.active_constraints, 0);
    for (int j = 0; j < 15; ++j) EXPECT_NEAR(mono.weights[j], free.weights[j], 1e-9) << j;
}

TEST(IdentPi, ShanGridRecoversExponentialDensityWeights) {
    const auto& s = golden()["shan"];
    const std::vector<double> u = s["u"], y = s["y"], r = s["thresholds"], w = s["weights"];
    PiFitOptions o;
    o.grid = ThresholdGrid::kShan;
    o.rho = s["rho"];
    o.operators = 8;
    const PiFitResult res = fit_pi(u, y, o);
    ASSERT_EQ(res.thresholds.size(), 8u);
    for (int j = 0; j < 8; ++j) EXPECT_NEAR(res.thresholds[j], r[j], 1e-15) << j;
    // Noise-free data from this very model: the weights come back to the
    // rounding of the data (cond ~1e3 * 1e-16 relative).
    for (int j = 0; j < 9; ++j) EXPECT_NEAR(res.weights[j], w[j], 1e-10 * w.back()) << j;
    EXPECT_LT(res.rms_error, 1e-6);  // the float PiModel's rounding (|y| ~ 3)
}

TEST(IdentPi, SamplesBeforeFirstFittedOnlyRunThePlays) {
    // The Shan2012 data with its first 100 outputs corrupted (a transient
    // the model does not describe): fitted from sample 100 on, the weights
    // come back as from the clean data, since the plays still run through
    // the skipped inputs; the errors are those of the fitted samples.
    const auto& s = golden()["shan"];
    const std::vector<double> u = s["u"], w = s["weights"];
    std::vector<double> y = s["y"];
    for (std::size_t k = 0; k < 100; ++k) y[k] += 5.0 * std::sin(0.3 * static_cast<double>(k));
    PiFitOptions o;
    o.grid = ThresholdGrid::kShan;
    o.rho = s["rho"];
    o.operators = 8;
    EXPECT_GT(fit_pi(u, y, o).rms_error, 1e-2);  // the corruption spoils a fit of every sample
    o.first_fitted = 100;
    const PiFitResult res = fit_pi(u, y, o);
    for (int j = 0; j < 9; ++j) EXPECT_NEAR(res.weights[j], w[j], 1e-10 * w.back()) << j;
    EXPECT_LT(res.rms_error, 1e-6);
    EXPECT_LT(res.max_error, 1e-5);
    o.first_fitted = u.size();
    EXPECT_THROW(fit_pi(u, y, o), std::invalid_argument);
}

TEST(IdentPi, NnlsSatisfiesKkt) {
    // Random problems: x >= 0, gradient g = A'(Ax - b) is 0 on free variables
    // and >= 0 on those held at 0 (optimality of the convex problem).
    std::mt19937_64 rng(42);
    std::normal_distribution<double> n01(0.0, 1.0);
    for (int trial = 0; trial < 20; ++trial) {
        Eigen::MatrixXd a(30, 8);
        Eigen::VectorXd b(30);
        for (int i = 0; i < 30; ++i) {
            b(i) = n01(rng);
            for (int j = 0; j < 8; ++j) a(i, j) = n01(rng);
        }
        const std::vector<double> xs = nnls(a, b);
        const Eigen::VectorXd x = Eigen::Map<const Eigen::VectorXd>(xs.data(), 8);
        const Eigen::VectorXd grad = a.transpose() * (a * x - b);
        for (int j = 0; j < 8; ++j) {
            EXPECT_GE(x(j), 0.0);
            // Tolerances: 1e-10 of |A'b| (rounding of a 30x8 LS solve).
            if (x(j) > 0) EXPECT_NEAR(grad(j), 0.0, 1e-10 * (a.transpose() * b).norm()) << trial;
            else EXPECT_GE(grad(j), -1e-10 * (a.transpose() * b).norm()) << trial;
        }
    }
}

TEST(IdentPi, RefusesDataThatCannotIdentifyTheWeights) {
    const auto& g = golden();
    const std::vector<double> u = g["u"], y = g["set15"]["y"];
    PiFitOptions o;

    const std::vector<double> flat(500, 2.0), yflat(500, 1.0);
    EXPECT_EQ(error_of([&] { fit_pi(flat, yflat, o); }), "u: no excitation: the input is constant");

    // A square wave between 0 and 5: after the first cycle every play
    // repeats the same two values, so the regressors span three directions.
    std::vector<double> sq(600), ysq(600);
    for (int k = 0; k < 600; ++k) sq[k] = (k / 50) % 2 ? 0.0 : 5.0;
    for (int k = 0; k < 600; ++k) ysq[k] = sq[k];
    o.operators = 4;
    const std::string dep = error_of([&] { fit_pi(sq, ysq, o); });
    EXPECT_EQ(dep.rfind("u: play regressors are linearly dependent", 0), 0u) << dep;

    // Thresholds above the input's reach give zero regressors.
    o.thresholds = {1.0, 5.0, 12.0};
    const std::string far = error_of([&] { fit_pi(u, y, o); });
    EXPECT_EQ(far.rfind("thresholds[2]: 12 is never reached by u", 0), 0u) << far;
    o.thresholds = {1.0, 0.5};
    EXPECT_EQ(error_of([&] { fit_pi(u, y, o); }), "thresholds[1]: thresholds must be strictly ascending");
    o.thresholds = {0.0, 0.5};
    EXPECT_EQ(error_of([&] { fit_pi(u, y, o); }).rfind("thresholds[0]: must be finite and > 0", 0), 0u);
    o.thresholds.clear();
    o.operators = 17;
    EXPECT_EQ(error_of([&] { fit_pi(u, y, o); }).rfind("operators: must be in [1, 16]", 0), 0u);
    o.operators = 0;
    EXPECT_EQ(error_of([&] { fit_pi(u, y, o); }).rfind("operators: must be in [1, 16]", 0), 0u);
    o.operators = 4;
    o.grid = ThresholdGrid::kShan;
    o.rho = -0.1;
    EXPECT_EQ(error_of([&] { fit_pi(u, y, o); }), "rho: must be finite and > 0");
    o = PiFitOptions{};
    o.input_name = "v_V";
    o.output_name = "x_um";
    std::vector<double> ynan = y;
    ynan[3] = INFINITY;
    EXPECT_EQ(error_of([&] { fit_pi(u, ynan, o); }), "x_um: sample 3 is not finite (NaN/Inf)");
    EXPECT_EQ(error_of([&] { fit_pi(std::span<const double>(u.data(), 20), std::span<const double>(y.data(), 20), o); })
                  .rfind("v_V: too short", 0),
              0u);
    EXPECT_EQ(error_of([&] { fit_pi(u, std::span<const double>(y.data(), 20), o); })
                  .rfind("x_um: has 20 samples but v_V has 3000", 0),
              0u);
    o.monotone = true;
    o.min_slope = 0.0;
    EXPECT_EQ(error_of([&] { fit_pi(u, y, o); }).rfind("min_slope: must be > 0", 0), 0u);
}

}  // namespace
