// Prandtl–Ishlinskii weight fit (docs/models.md, 'Identification'): thresholds on a grid, weights by
// linear least squares on the play-operator regressors (the model
//     y[k] = p0 u[k] + sum_j p_j F_{r_j}[u][k]
// is linear in the weights), optionally constrained to a monotone loading
// curve so the result has an analytic inverse (docs/models.md, 'Analytic PI inverse').
//
// Plays start from w = 0 before the first sample, as PiOperator<float> after
// reset() does (for the first input that is Janaideh2016's initial state).
//
// Unconstrained: Householder QR of the regressor matrix (columns normalised
// to unit RMS, which is also where the conditioning is checked).
// Monotone: the loading-curve slopes P_j = p0 + sum_{i<=j} p_i are the
// unknowns (p = D P with D the first-difference matrix, so the regressor
// matrix becomes Phi D), each bounded below by min_slope > 0: P = min_slope
// + P', P' >= 0, solved by Lawson–Hanson active-set non-negative least
// squares on the triangular R factor of Phi D (same minimiser, small system).
// The constrained optimum is unique when the regressors have full rank.
#pragma once

#include <functional>
#include <span>
#include <string>
#include <vector>

#include <Eigen/Dense>

#include "piezoloop/pi_model.hpp"

namespace piezoloop::design {

enum class ThresholdGrid {
    kUniform,  // r_j = j * reach / (n + 1), reach = max |u| (plays start at 0)
    kShan,     // Shan2012: r_j = rho * j (rho given; reach/(n+1) if rho == 0)
};

struct PiFitOptions {
    int operators = 10;  // play operators besides the linear term, 1..16
    ThresholdGrid grid = ThresholdGrid::kUniform;
    double rho = 0.0;               // kShan spacing (> 0), 0: reach/(n+1)
    std::vector<double> thresholds; // explicit thresholds (> 0, ascending); overrides the grid
    bool monotone = false;          // constrain every P_j >= min_slope
    // Smallest allowed loading-curve slope in the monotone fit, output per
    // input unit. < 0: 1e-3 * (max y - min y) / (max u - min u).
    double min_slope = -1.0;
    // Samples before this one only run the plays (their history), outside the
    // fit and its errors: a transient the model does not describe (a
    // stage's mode ringing after a jump to the first input).
    std::size_t first_fitted = 0;
    std::string input_name = "u";   // column names used in error messages
    std::string output_name = "y";
    // Called now and then on long data ("regressors: 3 Mi of 10 Mi rows").
    std::function<void(const std::string&)> progress;
};

struct PiFitResult {
    PiModel model;                  // plain model (gain 1, offset 0): p0 + the play operators
    std::vector<double> thresholds; // r_1..r_n (double, as fitted)
    std::vector<double> weights;    // p0, p_1..p_n (double, as fitted)
    std::vector<double> slopes;     // P_0..P_n of the loading curve
    double min_slope = 0.0;         // bound used (monotone fits)
    int active_constraints = 0;     // slopes held at min_slope (monotone fits)
    // Fit errors of the float PiModel evaluated by PiOperator<float> on u:
    double rms_error = 0.0;
    double max_error = 0.0;
    double nrmse_percent = 0.0;     // 100 * rms_error / rms(y - mean y)
    double regressor_condition = 0.0;
    bool invertible = false;        // invert_pi(model) succeeded
    std::string invertibility;      // "ok" or the failing segment (describe(Status))
};

// Play output F_r[u] with w = 0 before the first sample, in double.
std::vector<double> play_regressor(std::span<const double> u, double r);

// Thresholds the options select for input u (validated).
std::vector<double> pi_fit_thresholds(std::span<const double> u, const PiFitOptions& options);

// Fits the weights. Throws std::invalid_argument naming the column or field
// for: operators outside 1..16, bad explicit thresholds, sizes that differ,
// NaN/Inf, fewer than max(3 (n+1), 20) samples, a constant input, a play
// whose threshold the input never reaches (its regressor is zero), and
// regressors whose normalised condition number exceeds 1e10.
PiFitResult fit_pi(std::span<const double> u, std::span<const double> y, const PiFitOptions& options);

// Lawson–Hanson: min |A x - b| subject to x >= 0 (exposed for tests).
std::vector<double> nnls(const Eigen::MatrixXd& A, const Eigen::VectorXd& b, int max_iterations = 0);

}  // namespace piezoloop::design
