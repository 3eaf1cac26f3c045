// Dahl model identification (docs/models.md, 'Identification'): Levenberg–Marquardt fit of
// (alpha1, alpha2, beta1, beta2, ga) — with gamma_a held — to a measured
// or simulated loop, voltage v in, displacement x out, using the plant form
// of common/piezoloop/dahl.hpp: x = ga v - H(x).
//
// Why gamma_a is held, not fitted: from the virgin state z = 0 the state is
// linear in B_H = [0, gamma_a], so z = gamma_a * z(gamma_a = 1) and H depends
// on gamma_a only through beta1*gamma_a and beta2*gamma_a. The six published
// parameters are therefore not identifiable from any data: (gamma_a, beta1,
// beta2) -> (c gamma_a, beta1/c, beta2/c) gives the same loops. The fit holds
// gamma_a at the value given (e.g. a published one) and identifies the rest.
//
// Simulation: a double-precision port of DahlActuator's equations (same
// model, same per-sample solve of x + H(x) = ga v along the path, same stick
// rule at a reversal), but with the exact 2x2 matrix exponential of
// A_H(s)*dx per trial increment instead of the float trapezoidal sub-steps,
// and Newton iterated to double rounding. The fit's Jacobian is formed by
// finite differences, which needs a model output that is smooth in the
// parameters down to ~1e-12; the float plant (rounding ~1e-7, a solver
// tolerance, sub-step counts that jump with the parameters) is not. Tests
// check that the port and DahlActuator agree to float accuracy.
//
// Convergence: the LM works on scaled unknowns (log alpha1, log alpha2,
// log ga — positive and scale free — and beta1, beta2 divided by their
// starting magnitudes), and starts from an equation-error estimate: for
// each (alpha1, alpha2) on a log grid around the data's path length L
// (sqrt(alpha2) in {1/4 .. 8}/L, alpha1/sqrt(alpha2) in {0.1 .. 4}), the
// integrator driven by the measured x (made monotone between input
// reversals so noise adds no fake reversals) gives z, and x = ga v -
// beta2 gamma_a z1 - beta1 gamma_a s z2 is linear in (ga, beta1, beta2):
// one small least-squares problem per grid point. LM then runs from the
// three best grid points and the lowest output error wins.
//
// Where the model starts (DahlStartState): the model's state depends on the
// whole history of its path, and with alpha1 ~ 0 (the only case in which a
// loop persists over many periods, dahl.hpp) it never forgets it: no
// warm-up, however long, makes the start irrelevant. A record that begins
// mid-loop, after a history nobody recorded, therefore cannot be fitted
// from the virgin state at its first sample. kEstimated starts the model
// from the virgin state at an unknown voltage v0 (a sixth unknown, fitted
// with the others) and moves it straight to the first fitted sample's
// voltage: the history of a stage that rested at v0 and was then driven to
// where the record starts (the real recording of docs/identification.md
// rested at 0 V and jumps to 1.8 V). One unknown, not the two components of
// z: with the offset fitted, a free z and the betas trade off exactly
// ((beta, z - z_eq) -> (c beta, (z - z_eq)/c) leaves H up to a constant),
// so z could not be identified; the virgin start at v0 ties its size to
// z_eq. kVirgin is the model from the virgin state at the first sample, the
// samples before the first fitted one only running it.
#pragma once

#include <functional>
#include <limits>
#include <optional>
#include <span>
#include <string>
#include <vector>

#include "piezoloop/dahl.hpp"

namespace piezoloop::design {

struct DahlParamsD {
    double alpha1 = 0.0, alpha2 = 0.0, beta1 = 0.0, beta2 = 0.0, gamma_a = 0.0, ga = 0.0;
    static DahlParamsD from(const DahlParams& p) {
        return {p.alpha1, p.alpha2, p.beta1, p.beta2, p.gamma_a, p.ga};
    }
    DahlParams to_float() const {
        return {static_cast<float>(alpha1), static_cast<float>(alpha2), static_cast<float>(beta1),
                static_cast<float>(beta2),  static_cast<float>(gamma_a), static_cast<float>(ga)};
    }
};

// The plant x = ga v - H(x) from the virgin state (z = 0, x = ga v[0],
// direction +), in double; same semantics as DahlActuator::reset(v[0]) and
// step(v[k]) for k >= 0.
std::vector<double> simulate_dahl_plant(const DahlParamsD& p, std::span<const double> v);

// The plant from the virgin state at v0, moved straight to v[first] (its
// output there is the first sample returned), then along v[first + 1 ..].
// Returns v.size() - first samples.
std::vector<double> simulate_dahl_plant_from(const DahlParamsD& p, double v0, std::span<const double> v,
                                             std::size_t first);

enum class DahlStartState { kVirgin, kEstimated };

struct DahlFitOptions {
    double gamma_a = 1.0;               // held (see above); must be finite and non-zero
    std::optional<DahlParamsD> start;   // starting point (its gamma_a is replaced by gamma_a); else grid
    int max_evaluations = 4000;         // model simulations per LM run
    // Fit a constant output offset c (x_measured = c + x_model): eliminated
    // from the LM by variable projection (for any parameters the best c is
    // the mean residual), so the LM keeps its five unknowns.
    bool fit_offset = false;
    double max_nrmse_percent = 10.0;    // above: flagged poor_fit
    // First sample in the fit. kAutoFirstFitted: the input's first turning
    // point (its first extremum, the input moving back by more than 1 % of
    // its span after it): it skips a stage's transient after the jump to the
    // record's first value, and from a virgin record the straight move of
    // kEstimated to the turning point is the record's own history.
    static constexpr std::size_t kAutoFirstFitted = std::numeric_limits<std::size_t>::max();
    std::size_t first_fitted = 0;
    DahlStartState start_state = DahlStartState::kVirgin;  // see "Where the model starts"
    // The last fraction of the record, kept out of the fit to validate it
    // (0 <= holdout <= 0.9; the model runs through it).
    double holdout = 0.0;
    std::string input_name = "v";       // column names used in error messages
    std::string output_name = "x";
    // Called after every model simulation with what the fit is doing
    // ("LM run 2 of 4, 120 simulations"); for progress output.
    std::function<void(const std::string&)> progress;
};

struct DahlFitResult {
    DahlParamsD params;       // identified (gamma_a as held)
    DahlParams params_float;  // the same, as the core's DahlParams
    // Products that do not depend on the gamma_a convention.
    double beta1_gamma_a = 0.0, beta2_gamma_a = 0.0;
    // Standard errors from the Gauss–Newton covariance rms^2 (J^T J)^-1 at
    // the optimum, in the parameters' own units (alpha1, alpha2, beta1, beta2, ga).
    std::vector<double> std_errors;
    double rms_error = 0.0;      // rms(x - x_model)
    double max_error = 0.0;
    double nrmse_percent = 0.0;  // 100 rms_error / rms(x - mean x)
    double offset = 0.0;         // c (0 unless fit_offset): the model's output at v = 0 from the virgin state
    std::size_t first_fitted = 0;    // resolved when automatic
    std::size_t validated_from = 0;  // first held-out sample (= the size without holdout)
    std::size_t fitted_samples = 0;
    // kEstimated: the voltage of the virgin start and its standard error.
    std::optional<double> virgin_V, virgin_V_std_error;
    // On the held-out samples (the offset as fitted; NRMSE normalised by
    // their own spread); samples = 0 without holdout.
    double validation_rms_error = 0.0, validation_max_error = 0.0, validation_nrmse_percent = 0.0;
    std::size_t validation_samples = 0;
    bool poor_fit = false;       // the NRMSE judged (held-out with a holdout, else fitted) > max_nrmse_percent
    double jacobian_condition = 0.0;  // column-normalised, at the optimum
    int evaluations = 0;         // model simulations, all runs
    int starts = 0;              // LM runs
    std::string termination;     // LM status of the winning run
};

// Throws std::invalid_argument naming the column or field for: sizes that
// differ, NaN/Inf, fewer than 50 samples, a constant v or x, invalid
// options (first_fitted at or beyond the held-out part, no turning point for
// kAutoFirstFitted, holdout outside [0, 0.9], fewer than 50 fitted
// samples), and data that cannot identify the parameters: a Jacobian at the
// optimum whose column-normalised condition number exceeds 1e8 (the message
// names the parameters that the data cannot separate), or a standard error
// above 50 % of the value of alpha1, alpha2, beta2 or ga (named with value
// and error; e.g. loops much shorter than the transient length 2/alpha1).
DahlFitResult fit_dahl(std::span<const double> v, std::span<const double> x, const DahlFitOptions& options);

}  // namespace piezoloop::design
