// The multiplicative uncertainty weight W3 of a fitted model from its error
// on the measured lines ("the spread between fitted model and
// measured response becomes the multiplicative uncertainty weight"):
//
//   δ_i = |G_i / G_fit(jω_i) - 1|  on the lines measured with SNR >= 20 dB,
//   W3(s) = r0 (1 + s/ω_z) / (1 + s/ω_p),  ω_p = ω_z r∞ / r0,
//
// a first-order lead from r0 (the error at the lowest lines, at least 2 %)
// to r∞ = 2 (200 %: beyond the band the model says nothing), with the
// largest ω_z for which |W3(jω_i)| >= δ_i at every line (bisection on
// log ω_z; |W3(jω)| falls as ω_z grows). Lines the weight cannot cover
// (δ_i near or above r∞) are left out of the search and counted. A loop with
// ‖W3 T‖∞ < 1 stays stable for every plant G_fit (1 + Δ W3), ‖Δ‖∞ <= 1.
#pragma once

#include <vector>

#include "lti/lti.hpp"

namespace piezoloop::commission {

struct UncertaintyWeight {
    design::Zpk w3;           // continuous
    double r0 = 0.0, r_inf = 2.0, wz_rad_s = 0.0, wp_rad_s = 0.0;
    int uncovered_lines = 0;  // lines where |W3| < δ
};

// f_Hz ascending, delta >= 0 (the same length, at least one line). Throws
// std::invalid_argument naming "frf" for bad input.
UncertaintyWeight uncertainty_weight(const std::vector<double>& f_Hz, const std::vector<double>& delta);

}  // namespace piezoloop::commission
