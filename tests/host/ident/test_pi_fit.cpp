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

#include "ident/csv_data.hpp"
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

// A 1 Hz-like periodic wave between 0 and 3.6 starting at mid-range (as the
// micromanipulator recording), `periods` periods of 200 samples.
std::vector<double> periodic_wave(int periods) {
    std::vector<double> u;
    for (int k = 0; k < 200 * periods + 50; ++k) u.push_back(1.8 - 1.8 * std::cos(2.0 * M_PI * (k + 50) / 200.0));
    return u;
}

// y = c + p0 u + sum p_j F_rj[u], plays from the given initial states (not
// at rest: the fit must not rely on them).
std::vector<double> pi_output(const std::vector<double>& u, double c, const std::vector<double>& r,
                              const std::vector<double>& p, std::vector<double> w) {
    std::vector<double> y;
    for (double x : u) {
        double v = c + p[0] * x;
        for (std::size_t j = 0; j < r.size(); ++j) {
            w[j] = std::max(x - r[j], std::min(x + r[j], w[j]));
            v += p[j + 1] * w[j];
        }
        y.push_back(v);
    }
    return y;
}

TEST(IdentPi, RecoversOffsetAndWeightsFromPeriodicDataWithUnknownInitialStates) {
    const std::vector<double> u = periodic_wave(6);
    const std::vector<double> r = {0.3, 0.6, 0.9, 1.2, 1.5}, p = {2.0, 3.0, 2.0, 1.5, 1.0, 0.5};
    const double c = -118.0;
    const std::vector<double> y = pi_output(u, c, r, p, {0.7, -1.0, 2.5, 0.0, 3.0});
    PiFitOptions o;
    o.thresholds = r;
    o.fit_offset = true;
    o.first_fitted = PiFitOptions::kAutoFirstFitted;
    o.holdout = 0.25;
    const PiFitResult res = fit_pi(u, y, o);
    // The largest play (r = 1.5) forgets its start once the input has risen
    // to 3.6 and come down by 3: at 0.6, on the first descent (sample 150 - 53).
    EXPECT_GT(res.first_fitted, 50u);
    EXPECT_LT(res.first_fitted, 150u);
    for (std::size_t k = res.first_fitted - 1; k + 1 < res.first_fitted; ++k) EXPECT_GT(u[k], u[k + 1]);
    // Noise-free data of the model class: least squares is exact up to
    // rounding (condition number ~1e2, values ~1e2): 1e-8.
    for (int j = 0; j < 6; ++j) EXPECT_NEAR(res.weights[j], p[j], 1e-8) << j;
    EXPECT_NEAR(res.offset, c, 1e-8);
    // Offset after a descent to 0: analytically c + sum p_j r_j, and the
    // data's own value at every lower turning point (u = 0 at samples 150 + 200 m).
    double descended = c;
    for (std::size_t j = 0; j < r.size(); ++j) descended += p[j + 1] * r[j];
    EXPECT_NEAR(res.offset_after_descent, descended, 1e-8);
    EXPECT_NEAR(res.offset_after_descent, y[350], 1e-9);
    // Held-out: the last quarter, errors of the float model (rounding ~1e-5 of 120).
    EXPECT_EQ(res.validated_from, u.size() - u.size() / 4);
    EXPECT_EQ(res.validation.samples, u.size() / 4);
    EXPECT_LT(res.validation.max_error, 1e-4);
    EXPECT_LT(res.nrmse_percent, 1e-3);
    EXPECT_FALSE(res.poor_fit);
    EXPECT_TRUE(res.invertible);
    // Without the offset the same data cannot be fitted: flagged.
    o.fit_offset = false;
    const PiFitResult bad = fit_pi(u, y, o);
    EXPECT_TRUE(bad.poor_fit);
    EXPECT_GT(bad.judged_nrmse_percent, 10.0);
}

TEST(IdentPi, MonotoneFitWithOffsetMeetsTheOptimalityConditions) {
    // The non-monotone golden data read with an offset of 5, fitted with
    // the offset free and the slopes bounded: checked against the KKT
    // conditions of min |y - c - Phi D P|^2, P >= m, on the regressors built
    // here: the gradient is 0 in c and in every P_j above the bound and
    // points into the bound (>= 0 for the objective) where P_j = m.
    const auto& g = golden();
    const auto& c = g["nonmonotone"];
    const std::vector<double> u = g["u"], r = c["thresholds"];
    std::vector<double> y = c["y"];
    for (double& v : y) v += 5.0;
    PiFitOptions o;
    o.thresholds = r;
    o.fit_offset = true;
    o.monotone = true;
    o.min_slope = c["min_slope"];
    const PiFitResult res = fit_pi(u, y, o);
    EXPECT_GE(res.active_constraints, 1);
    const Eigen::MatrixXd phi = regressors(u, r);
    const int n = static_cast<int>(phi.cols());
    Eigen::VectorXd p(n);
    for (int j = 0; j < n; ++j) p(j) = res.weights[j];
    const Eigen::VectorXd yv = Eigen::Map<const Eigen::VectorXd>(y.data(), static_cast<Eigen::Index>(y.size()));
    const Eigen::VectorXd e = yv - phi * p - Eigen::VectorXd::Constant(yv.size(), res.offset);
    Eigen::MatrixXd d = Eigen::MatrixXd::Identity(n, n);
    for (int j = 1; j < n; ++j) d(j, j - 1) = -1.0;
    const Eigen::VectorXd grad = -(phi * d).transpose() * e;  // d(|e|^2/2)/dP
    // Rounding of sums over 3000 rows: 1e-9 of |(Phi D)' y|.
    const double tol = 1e-9 * ((phi * d).transpose() * yv).norm();
    EXPECT_NEAR(e.sum(), 0.0, 1e-9 * yv.cwiseAbs().sum());
    int at_bound = 0;
    for (int j = 0; j < n; ++j) {
        EXPECT_GE(res.slopes[j], o.min_slope - 1e-12) << j;
        if (res.slopes[j] > o.min_slope + 1e-9) {
            EXPECT_NEAR(grad(j), 0.0, tol) << j;
        } else {
            ++at_bound;
            EXPECT_GE(grad(j), -tol) << j;
        }
    }
    EXPECT_EQ(at_bound, res.active_constraints);
    EXPECT_TRUE(res.invertible) << res.invertibility;
}

TEST(IdentPi, UniformGridWithOffsetStaysBelowHalfTheSpan) {
    // With an offset a play that never turns is a constant: the grid covers
    // half the input span (1.8 here), not max |u| (3.6).
    const std::vector<double> u = periodic_wave(3);
    PiFitOptions o;
    o.operators = 8;
    o.fit_offset = true;
    const std::vector<double> r = pi_fit_thresholds(u, o);
    ASSERT_EQ(r.size(), 8u);
    for (int j = 0; j < 8; ++j) EXPECT_NEAR(r[j], 1.8 * (j + 1) / 9.0, 1e-12) << j;
    o.fit_offset = false;
    EXPECT_NEAR(pi_fit_thresholds(u, o).back(), 3.6 * 8 / 9.0, 1e-12);
}

TEST(IdentPi, ModifiedPiRecoversTheOutputNonlinearityAndInverts) {
    const std::vector<double> u = periodic_wave(6);
    const std::vector<double> r = {0.3, 0.6, 0.9, 1.2, 1.5}, p = {4.0, 3.0, 2.0, 1.5, 1.0, 0.5};
    const double c = -100.0;
    const std::vector<double> z = pi_output(u, c, r, p, {0.0, 0.0, 0.0, 0.0, 0.0});
    // g = S^-1 with slopes 1, 0.7, 0.5, 0.9 (a loading curve that steepens
    // and flattens: not PI-shaped).
    DeadZoneMap g;
    g.thresholds = {-88.0, -80.0, -72.0};  // inside the output's range (-94.6 .. -54)
    g.weights = {-0.3, -0.2, 0.4};
    const DeadZoneMap s = inverse(g);
    std::vector<double> y;
    for (double v : z) y.push_back(s.apply(v));
    // S inverts g (analytic): g(S(z)) = z.
    for (double v : {-110.0, -86.0, -79.0, -75.0, -60.0}) EXPECT_NEAR(g.apply(s.apply(v)), v, 1e-12);
    PiFitOptions o;
    o.thresholds = r;
    o.fit_offset = true;
    o.first_fitted = PiFitOptions::kAutoFirstFitted;
    o.output_thresholds = g.thresholds;
    const PiFitResult res = fit_pi(u, y, o);
    // Noise-free data of the model class, same thresholds: exact up to rounding.
    for (int j = 0; j < 6; ++j) EXPECT_NEAR(res.weights[j], p[j], 1e-8) << j;
    EXPECT_NEAR(res.offset, c, 1e-7);
    ASSERT_EQ(res.output_inverse.weights.size(), 3u);
    for (int i = 0; i < 3; ++i) EXPECT_NEAR(res.output_inverse.weights[i], g.weights[i], 1e-9) << i;
    EXPECT_EQ(res.active_constraints, 0);
    EXPECT_LT(res.nrmse_percent, 1e-3);  // float PI rounding only
    // A plain PI on the same data misses the curvature.
    PiFitOptions plain = o;
    plain.output_thresholds.clear();
    const double plain_nrmse = fit_pi(u, y, plain).nrmse_percent;
    EXPECT_GT(plain_nrmse, 100 * res.nrmse_percent);
    // The compensator: the input that gives the model's own output back is
    // the input (float inverse PI: 1e-4 of the 3.6 span).
    ASSERT_TRUE(res.invertible) << res.invertibility;
    const std::vector<double> ym = res.simulate(u);
    for (std::size_t k = 0; k < u.size(); k += 7) EXPECT_NEAR(ym[k], y[k], 1e-8) << k;
    const std::vector<double> back = res.invert(ym);
    for (std::size_t k = 0; k < u.size(); ++k) ASSERT_NEAR(back[k], u[k], 1e-4) << k;
    // The same compensator as the core's PiModel (the map g as dead zones,
    // in float), run by the float operator: the input back to the same
    // 1e-4 of the span, and within 1e-5 V of invert(), whose g is in double
    // (float rounding of g near -100 um: ~1e-5 um, times the inverse's
    // slope below 1 V/um).
    const PiModel comp = res.compensator();
    ASSERT_EQ(comp.dead_zones, 3);
    PiOperator<float> core;
    ASSERT_TRUE(core.configure(comp).ok());
    for (std::size_t k = 0; k < u.size(); ++k) {
        const double v = core.apply(static_cast<float>(ym[k]));
        ASSERT_NEAR(v, u[k], 1e-4) << k;
        ASSERT_NEAR(v, back[k], 1e-5) << k;
    }
    // Default grid (equal split of the range, not the model's thresholds):
    // not exact, still well below the plain PI's error.
    o.output_thresholds.clear();
    o.output_dead_zones = 3;
    const PiFitResult grid = fit_pi(u, y, o);
    std::printf("curved output: plain PI %.2f %%, 3 dead zones on the default grid %.2f %%\n", plain_nrmse,
                grid.nrmse_percent);
    EXPECT_LT(grid.nrmse_percent, 0.5 * plain_nrmse);
    for (double sl : grid.output_inverse.slopes()) EXPECT_GE(sl, o.min_output_slope - 1e-12);
}

TEST(IdentPi, PoorFitIsFlaggedOnDataNoPiModelFits) {
    // Output unrelated to the input: any PI model misses by ~100 %.
    const std::vector<double> u = periodic_wave(4);
    std::mt19937_64 rng(7);
    std::normal_distribution<double> n01(0.0, 1.0);
    std::vector<double> y;
    for (std::size_t k = 0; k < u.size(); ++k) y.push_back(n01(rng));
    PiFitOptions o;
    o.fit_offset = true;
    o.first_fitted = PiFitOptions::kAutoFirstFitted;
    o.holdout = 0.25;
    const PiFitResult res = fit_pi(u, y, o);
    EXPECT_TRUE(res.poor_fit);
    EXPECT_GT(res.judged_nrmse_percent, 90.0);
    EXPECT_EQ(res.judged_nrmse_percent, res.validation.nrmse_percent);
}

TEST(IdentPi, RefusesBadHoldoutDeadZonesAndAnInputThatNeverForgets) {
    const std::vector<double> u = periodic_wave(3);
    const std::vector<double> y = pi_output(u, 1.0, {0.5}, {1.0, 0.5}, {0.0});
    PiFitOptions o;
    o.fit_offset = true;
    o.holdout = 1.0;
    EXPECT_EQ(error_of([&] { fit_pi(u, y, o); }), "holdout: must be in [0, 1)");
    o.holdout = 0.0;
    o.output_dead_zones = 9;
    EXPECT_EQ(error_of([&] { fit_pi(u, y, o); }), "output_dead_zones: must be in [0, 8]");
    o.output_dead_zones = 0;
    o.output_thresholds = {2.0, 1.0};
    EXPECT_EQ(error_of([&] { fit_pi(u, y, o); }), "output_thresholds[1]: must be finite and strictly ascending");
    o.output_thresholds.clear();
    // The wave spans 3.6: a play of threshold 2 never forgets its state
    // before the record (it needs a travel of 4 in one direction).
    o.thresholds = {0.5, 2.0};
    o.first_fitted = PiFitOptions::kAutoFirstFitted;
    const std::string never = error_of([&] { fit_pi(u, y, o); });
    EXPECT_EQ(never.rfind("thresholds[1]: u never moves by 2 r = 4 in one direction", 0), 0u) << never;
    o.thresholds.clear();
    o.first_fitted = 0;
    o.holdout = 0.5;
    std::vector<double> tiny(u.begin(), u.begin() + 60), ytiny(y.begin(), y.begin() + 60);
    EXPECT_EQ(error_of([&] { fit_pi(tiny, ytiny, o); }).rfind("u: too short: 30 fitted samples", 0), 0u);
}

// The real recording (shared/data/piezo_micromanipulator, beside the
// repository; not in it): a piezo micromanipulator's command voltage
// (field 1) and capacitive sensor reading (field 5, offset ~ -100 um),
// 1 Hz, 200 samples a period. Fit on the first three quarters, validated
// on the last quarter (10 periods the fit did not see).
TEST(IdentPi, RealMicromanipulatorRecordingFromTheRawFile) {
    const std::string dir = std::string(PIEZOLOOP_GOLDEN_DIR) + "/../../../shared/data/piezo_micromanipulator/";
    if (!std::ifstream(dir + "Model_Vi_Do.dat"))
        GTEST_SKIP() << "no " << dir << "Model_Vi_Do.dat (the shared data folder sits beside the repository in CI)";
    const CsvData d = read_table(dir + "Model_Vi_Do.dat", parse_column_picks("u=1,y=5"));
    const std::vector<double>& u = d.column("u");
    const std::vector<double>& y = d.column("y");
    ASSERT_EQ(u.size(), 8027u);
    // Reference offset: the sensor at 0 V on the lower end of the periodic
    // loop, as the authors measured it: their y0 (authors_model/y0.dat) is the
    // lowest reading of the period from row 3152 (1-based) after they
    // subtracted that period's mean (Step01_GetModel.m), so in the raw
    // frame it is y0 + that mean.
    double y0 = 0.0;
    std::ifstream(dir + "authors_model/y0.dat") >> y0;
    ASSERT_NEAR(y0, -22.97, 0.01);
    double mean = 0.0, low = 1e300;
    for (int k = 3151; k < 3351; ++k) mean += y[k] / 200.0, low = std::min(low, y[k]);
    const double reference = y0 + mean;
    EXPECT_NEAR(reference, low, 1e-6);  // it is the period's lowest reading (-118.90 um)

    PiFitOptions o;
    o.operators = 16;
    o.fit_offset = true;
    o.first_fitted = PiFitOptions::kAutoFirstFitted;
    o.holdout = 0.25;
    const PiFitResult pi = fit_pi(u, y, o);
    o.output_dead_zones = 3;
    const PiFitResult mpi = fit_pi(u, y, o);
    std::printf("PI, 16 operators: NRMSE %.2f %% fitted (samples %zu..%zu), %.2f %% held out; offset %.3f um\n",
                pi.nrmse_percent, pi.first_fitted, pi.validated_from - 1, pi.validation.nrmse_percent,
                pi.offset_after_descent);
    std::printf("modified PI, 16 operators + 3 dead zones: NRMSE %.2f %% fitted, %.2f %% held out; offset %.3f um "
                "(reference %.3f um)\n",
                mpi.nrmse_percent, mpi.validation.nrmse_percent, mpi.offset_after_descent, reference);
    // The plays forget the recording's start (1.8 V, stage ringing) on the
    // first descent.
    EXPECT_LT(pi.first_fitted, 200u);
    // Plain PI: a usable model, not within 2 % (measured 2.26 / 2.47 %).
    EXPECT_FALSE(pi.poor_fit);
    EXPECT_LT(pi.validation.nrmse_percent, 3.0);
    // Modified PI: the target, <= 2 % on the held-out periods (measured 1.39 / 1.68 %).
    EXPECT_LE(mpi.validation.nrmse_percent, 2.0);
    EXPECT_LT(mpi.nrmse_percent, mpi.validation.nrmse_percent + 0.5);
    EXPECT_TRUE(mpi.invertible) << mpi.invertibility;
    // Offset to 1 % of the reference (measured 0.3 %: 0.3 um, less than the
    // sensor's 0.8 um creep over the record).
    EXPECT_LE(std::fabs(mpi.offset_after_descent - reference), 0.01 * std::fabs(reference));
    EXPECT_LE(std::fabs(pi.offset_after_descent - reference), 0.01 * std::fabs(reference));
}

}  // namespace
