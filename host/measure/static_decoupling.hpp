// A static decoupling of n coupled axes from their measured n x n frequency
// response G (y_i <- u_j, mimo_frf_estimate.hpp).
//
// G0, the static gain: the real part of the mean of G over the
// low-frequency lines (coupling.hpp's low_frequency_lines). Below the first
// mode G(e^{jwT}) = G(1) + j w G1 + O(w^2) with G(1), G1 real (the
// expansion of a real-coefficient response about w = 0), so the real part
// is the DC gain to O(w^2) and the imaginary part (delay, damping) drops
// out; no model or extrapolation is fitted.
//
// The output matrix D = G0^{-1} diag(G0), between the axis commands and the
// actuator channels (u = D v): G0 D = diag(G0), each axis keeps its own
// static gain and the static coupling is removed. Refused when G0 is
// ill-conditioned: the 1-norm condition ||G0||_1 ||G0^{-1}||_1 above
// max_condition (1000), where D would amplify the measurement's error.
// Predicted after it: the static coupling |(G0 D)_ij| / |(G0 D)_jj| (zero
// up to rounding, by construction) and, on the measured lines, the coupling
// of G(f) D (coupling.hpp): what is left from the dynamics and the
// imaginary part.
#pragma once

#include <optional>
#include <vector>

#include <Eigen/Dense>

#include "measure/coupling.hpp"

namespace piezoloop::measure {

struct StaticDecoupling {
    std::vector<int> low_lines;        // the lines G0 averages
    Eigen::MatrixXd g0;                // n x n
    double condition_1 = 0.0;          // 1-norm condition of G0
    Eigen::MatrixXd output_matrix;     // D: axis commands -> actuator channels
    Eigen::MatrixXd static_after_db;   // 20 log10 |(G0 D)_ij| / |(G0 D)_jj|; diagonal NaN; -inf where exactly 0
    Coupling after;                    // coupling of G(f) D on the measured lines
};

inline constexpr double kMaxDecouplingCondition = 1000.0;

// The 1-norm condition ||A||_1 ||A^{-1}||_1 (infinity when A is singular).
double condition_1(const Eigen::MatrixXd& a);

// Throws std::invalid_argument naming G0 when it is ill-conditioned or has a
// zero diagonal element, or naming below_Hz (coupling.hpp).
StaticDecoupling static_decoupling(const std::vector<double>& f_Hz, const std::vector<Eigen::MatrixXcd>& G,
                                   std::optional<double> below_Hz = std::nullopt,
                                   double max_condition = kMaxDecouplingCondition);

// The decoupling of a given static gain (the part of static_decoupling after
// G0 is known; `after` is left empty).
StaticDecoupling decouple_static_gain(const Eigen::MatrixXd& g0, double max_condition = kMaxDecouplingCondition);

}  // namespace piezoloop::measure
