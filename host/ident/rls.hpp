// Recursive least squares (docs/models.md, 'Identification'; Ahmad2020 eq. 1–3) and the linear
// discrete-time models it identifies from input/output data: ARX and
// output-error (OE).
//
// Model structures (q^-1 is the one-sample delay, d the input delay):
//   ARX:  A(q) y[k] = q^-d B(q) u[k] + e[k]
//   OE:   y[k] = q^-d B(q)/F(q) u[k] + e[k]
//   A(q) = 1 + a1 q^-1 + ... + a_na q^-na  (F likewise with nf = na)
//   B(q) = b0 + b1 q^-1 + ... + b_{nb-1} q^-(nb-1)
// so `delay` is the number of whole samples before u reaches y (1 for a
// strictly proper sampled plant). The identified model is returned as a
// discrete Tf in z (descending powers, den monic) with ts from the data.
//
// The OE model is fitted by Steiglitz–McBride: starting from the ARX
// estimate, u and y are filtered by 1/F of the previous iterate and an ARX
// model is fitted to the filtered data (by the same RLS), until F and B stop
// changing. For white output noise its fixed point is the OE estimate; each
// pass filters with F reflected inside the unit circle if an iterate is
// unstable. Ahmad2020 identify by RLS, i.e. the ARX structure.
#pragma once

#include <span>
#include <string>
#include <vector>

#include <Eigen/Dense>

#include "lti/lti.hpp"

namespace piezoloop::design {

// The recursion of Ahmad2020 eq. 1–3 in the notation of docs/models.md: theta is the
// regressor, Psi the parameter vector, W the covariance:
//   e0 = y - Psi' theta
//   W  = (W - W theta theta' W / (lambda + theta' W theta)) / lambda
//   Psi += W theta e0
// lambda in (0, 1] is the forgetting factor (1: none; 0.99 forgets with a
// time constant of ~100 samples).
class Rls {
public:
    Rls(const Eigen::VectorXd& initial_covariance_diagonal, double forgetting = 1.0);
    // One sample; returns the a-priori error e0.
    double update(const Eigen::VectorXd& theta, double y);
    const Eigen::VectorXd& parameters() const { return psi_; }
    const Eigen::MatrixXd& covariance() const { return w_; }

private:
    Eigen::VectorXd psi_;
    Eigen::MatrixXd w_;
    double lambda_;
};

enum class LinearStructure { kArx, kOutputError };

struct LinearIdentSpec {
    LinearStructure structure = LinearStructure::kArx;
    int na = 2;     // poles (A for ARX, F for OE), 0..20
    int nb = 2;     // numerator coefficients, 1..20
    int delay = 1;  // input delay in samples, 0..1000
    double forgetting = 1.0;  // RLS forgetting factor in (0, 1]
    // Initial covariance W0 = diag(initial_covariance / mean(regressor_i^2)),
    // i.e. a prior ~1e-6 as informative as one sample per regressor.
    double initial_covariance = 1e6;
    int max_iterations = 50;   // Steiglitz–McBride passes (OE)
    double tolerance = 1e-10;  // OE: stop when |d params| <= tolerance * |params|
    std::string input_name = "u";   // column names used in error messages
    std::string output_name = "y";
};

struct LinearIdentResult {
    Tf model;                // discrete, ts from the data; den = [1, a1, ...]
    std::vector<double> a;   // a1..a_na (ARX A or OE F)
    std::vector<double> b;   // b0..b_{nb-1}
    std::string method;      // "rls-arx" or "steiglitz-mcbride-oe"
    int iterations = 1;      // RLS passes over the data (OE: Steiglitz–McBride passes)
    bool converged = true;
    bool stable = true;      // all poles strictly inside the unit circle
    // Fit errors over the samples after the initial n = max(na, delay+nb-1):
    //  simulation: y_sim from u alone (initial n outputs taken from y);
    //  fit_percent = 100 (1 - |y - y_sim| / |y - mean(y)|) (NRMSE fit, 100 = exact);
    //  simulation_rms = rms(y - y_sim); prediction_rms = rms of the one-step
    //  ahead ARX equation error (for OE: of the final Steiglitz–McBride pass).
    double fit_percent = 0.0;
    double simulation_rms = 0.0;
    double prediction_rms = 0.0;
    double regressor_condition = 0.0;  // of the column-normalised regressor matrix
    int samples_used = 0;
};

// Identifies ARX or OE from u, y with sample period ts > 0. Throws
// std::invalid_argument naming the column or field when the data cannot
// identify the model: orders out of range, u and y of different length,
// NaN/Inf, fewer than max(3 p, 20) regression rows for p = na + nb
// parameters, a constant input, or regressors that are (nearly) linearly
// dependent (condition number > 1e10: the input is not persistently
// exciting of order na + nb); the message lists the dependent regressors.
LinearIdentResult identify_linear(std::span<const double> u, std::span<const double> y, double ts,
                                  const LinearIdentSpec& spec);

// Free-run simulation of A(q) y = q^-d B(q) u from zero initial state.
std::vector<double> simulate_arx(std::span<const double> a, std::span<const double> b, int delay,
                                 std::span<const double> u);

}  // namespace piezoloop::design
