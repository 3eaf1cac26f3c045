// Composition of a PI model with an estimated inverse, docs/models.md, 'Analytic PI inverse'
// (Janaideh2016 §III): applying P̂⁻¹ and then the true P gives another PI
// operator whose loading curve is η = φ ∘ ψ̂ (φ: P's loading curve, ψ̂:
// P̂⁻¹'s). Writing that operator as p0η v + Σ p_ηj F_{r_ηj}[v] and using
// F_r[v] = v − S_r[v] (play = input − stop, |S_r| <= r):
//     y = ρ v + Ξ,   ρ = p0η + Σ p_ηj,   |Ξ| <= Σ |p_ηj| r_ηj.
// ρ is the net linear gain the feedback loop sees and the bound on Ξ the
// disturbance it has to reject.
//
// η is piecewise linear: its breakpoints are ψ̂'s thresholds and the inputs
// v where ψ̂(v) reaches one of φ's thresholds; the weights p_ηj are the
// slope changes there and p0η the first slope (breakpoints within 1e-6 of
// the largest are merged: the models are float). The composition theorem
// needs increasing loading curves (then P ∘ P̂⁻¹ equals the PI operator of
// η exactly, for inputs starting from the zero state); `monotone` reports
// whether η is increasing. With an input amplitude limit V, operators with
// thresholds >= V never leave zero and drop out of both ρ and the bound.
//
// Both models must be plain PI models (input gain 1, offset 0: the form
// pi_model_from_lists and invert_pi produce).
#pragma once

#include <limits>
#include <vector>

#include "piezoloop/pi_model.hpp"

namespace piezoloop::design {

struct PiComposition {
    double p0 = 0.0;                  // first slope of η
    std::vector<double> thresholds;   // r_ηj, ascending, > 0
    std::vector<double> weights;      // p_ηj
    double rho = 0.0;                 // p0 + Σ p_ηj
    double xi_bound = 0.0;            // Σ |p_ηj| r_ηj
    bool monotone = true;             // η increasing (composition theorem applies)
    std::vector<double> curve_v;      // η at 0, every breakpoint and one step past the last
    std::vector<double> curve_eta;
};

PiComposition compose_pi(const PiModel& plant, const PiModel& inverse,
                         double max_input = std::numeric_limits<double>::infinity());

// Loading curve of a plain PI model in double precision.
double pi_loading_curve(const PiModel& m, double r);

}  // namespace piezoloop::design
