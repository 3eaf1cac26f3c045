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
//
// Output offset (fit_offset): a constant column joins the regressors; it is
// a free unknown, eliminated before the bounded problem (QR with it first,
// the bounds apply to the trailing block).
//
// Output nonlinearity (output_dead_zones = N > 0): Kuhnen's modified PI
// (K. Kuhnen, European Journal of Control 9(4), 2003), y = S(c + PI[u]),
// S a static increasing map. It is identified through its inverse
// g = S^-1, a superposition of dead zones on y (dead_zone_map.hpp):
//     g(y) = y + sum_i q_i max(y - d_i, 0) = c + p0 u + sum_j p_j F_rj[u],
// which is linear in (c, p, q) (Kuhnen's error model: the equation error in
// g's domain); d_i split the fitted y range into N + 1 equal parts. The
// slopes G_i = 1 + q_1 + ... + q_i of g are bounded below by
// min_output_slope (> 0), so S exists; the errors reported are those of y.
//
// First fitted sample: a play's output depends on its state before the
// record until the input has moved by 2 r in one direction; after that it
// does not. kAutoFirstFitted starts the fit at the first sample where the
// largest threshold's play has forgotten its initial state (found by running
// it from both extremes of its possible initial states until they agree).
#pragma once

#include <cstddef>
#include <limits>

#include <functional>
#include <span>
#include <string>
#include <vector>

#include <Eigen/Dense>

#include "ident/dead_zone_map.hpp"
#include "lti/decompositions.hpp"
#include "piezoloop/pi_model.hpp"

namespace piezoloop::design {

enum class ThresholdGrid {
    // r_j = j * reach / (n + 1), reach = max |u| (plays start at 0), or half
    // the input's span (max u - min u) / 2 with fit_offset (a play that
    // never turns is a constant there, not separable from the offset).
    kUniform,
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
    // kAutoFirstFitted: where every play has forgotten its initial state
    // (see above).
    static constexpr std::size_t kAutoFirstFitted = std::numeric_limits<std::size_t>::max();
    std::size_t first_fitted = 0;
    bool fit_offset = false;        // fit a constant output offset c
    // Fraction of the record, at its end, kept out of the fit and used to
    // validate it (0 <= holdout < 1; the plays run through it).
    double holdout = 0.0;
    int output_dead_zones = 0;      // N, 0..8: modified PI with an output nonlinearity
    // Explicit dead-zone thresholds d_i on y (ascending; their count
    // overrides output_dead_zones) instead of the equal split of the range.
    std::vector<double> output_thresholds;
    double min_output_slope = 0.01; // lower bound of g's slopes G_i
    // A fit whose NRMSE (on the held-out samples, else on the fitted ones)
    // exceeds this is flagged poor_fit.
    double max_nrmse_percent = 10.0;
    std::string input_name = "u";   // column names used in error messages
    std::string output_name = "y";
    // Called now and then on long data ("regressors: 3 Mi of 10 Mi rows").
    std::function<void(const std::string&)> progress;
};

struct FitErrors {
    double rms_error = 0.0;
    double max_error = 0.0;
    double nrmse_percent = 0.0;     // 100 * rms_error / rms(y - mean y) over the same samples
    std::size_t samples = 0;
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
    std::size_t first_fitted = 0;   // first sample in the fit (resolved when automatic)
    std::size_t validated_from = 0; // first held-out sample (= the size without holdout)
    FitErrors validation;           // on the held-out samples (samples = 0 without holdout)
    // y = S(offset + PI[u]) with the plays at rest (w = 0) before the first
    // sample; S is the identity without output nonlinearity.
    double offset = 0.0;
    // The model's output at input 0 after a descent to 0 from at least
    // 2 r_n above (every play at w_j = r_j): comparable with a sensor reading
    // at 0 on the lower end of periodic loops.
    double offset_after_descent = 0.0;
    DeadZoneMap output_inverse;     // g = S^-1 (empty without output nonlinearity)
    DeadZoneMap output_map;         // S
    bool poor_fit = false;          // judged NRMSE > max_nrmse_percent
    double judged_nrmse_percent = 0.0;
    bool invertible = false;        // invert_pi(model) succeeded (and S exists)
    std::string invertibility;      // "ok" or the failing segment (describe(Status))

    // The model's output for input u from rest, in double (S applied).
    std::vector<double> simulate(std::span<const double> u) const;
    // The compensator: the input that makes the model output y_desired,
    // u = PI^-1(g(y_desired) - offset), the inverse PI from invert_pi run from
    // rest. Throws std::invalid_argument when the model is not invertible.
    std::vector<double> invert(std::span<const double> y_desired) const;
    // The same compensator as the core runs it (PiModel): the input map g
    // as dead zones, the input offset -offset, the analytic PI inverse.
    // Throws std::invalid_argument when the model is not invertible.
    PiModel compensator() const;
};

// Play output F_r[u] with w = 0 before the first sample, in double.
std::vector<double> play_regressor(std::span<const double> u, double r);

// Thresholds the options select for input u (validated).
std::vector<double> pi_fit_thresholds(std::span<const double> u, const PiFitOptions& options);

// Fits the weights. Throws std::invalid_argument naming the column or field
// for: operators outside 1..16, bad explicit thresholds, sizes that differ,
// NaN/Inf, fewer than max(3 (n+1+N+offset), 20) fitted samples, a constant
// input, a play whose threshold the input never reaches (its regressor is
// zero), an automatic first sample that never comes (the input never moves
// by 2 r_n in one direction), holdout outside [0, 1), output_dead_zones outside
// 0..8, and regressors whose normalised condition number exceeds 1e10.
PiFitResult fit_pi(std::span<const double> u, std::span<const double> y, const PiFitOptions& options);

// Lawson–Hanson: min |A x - b| subject to x >= 0 (exposed for tests).
std::vector<double> nnls(const Eigen::MatrixXd& A, const Eigen::VectorXd& b, int max_iterations = 0);

}  // namespace piezoloop::design
