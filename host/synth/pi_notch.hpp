// The classic candidate a commissioning compares with the robust one: a PI
// controller with a notch at each lightly damped plant resonance above the
// crossover, tuned to a target crossover and lowered until the margins hold
// (what PI E-727 users tune by hand: a PID and notches against the graph).
//
//   K(s) = kp (s + ω_i) / (s + ω_l) · Π_r (s² + 2 ζ_r ω_r s + ω_r²) / (s² + 2 ζ_n ω_r s + ω_r²)
//
// ω_i = ω_c / integral_ratio (the PI zero a factor below crossover costs
// atan(1 / integral_ratio) of phase there); ω_l = leak · ω_c, the
// integrator's pole just off the origin: the core's sections refuse a pole
// on the unit circle, and at 1e-4 ω_c the leak leaves a DC loop gain of
// about 4e3 |G(0)| kp-units, far above what the tracking needs; each notch's zeros sit on a
// plant pole pair with ζ_r < resonance_damping_max and ω_r above 1.5 ω_c
// (they cancel it on the model; on the stage the cancellation is as good as
// the fit, which `analyze measured-loop` checks), its poles damped to ζ_n.
// kp sets |G K| = 1 at ω_c (its sign from the plant's low-frequency gain).
// If the loop is unstable or misses PM ≥ pm_min_deg or GM ≥ gm_min_db, ω_c
// is lowered by `step` until it meets them or falls below min_fraction of
// the target (then std::invalid_argument: no crossover meets the margins).
#pragma once

#include <string>
#include <vector>

#include "lti/lti.hpp"

namespace piezoloop::design {

struct PiNotchOptions {
    double integral_ratio = 4.0;
    double leak = 1e-4;
    double notch_damping = 0.7;
    double resonance_damping_max = 0.2;
    double pm_min_deg = 45.0;
    double gm_min_db = 6.0;
    double step = 0.9;
    double min_fraction = 0.05;
};

struct Notch {
    double f_Hz = 0.0;
    double plant_damping = 0.0;  // ζ_r of the zeros (the plant's pole pair)
    double notch_damping = 0.0;  // ζ_n of the poles
};

struct PiNotchDesign {
    Zpk controller;              // continuous, e -> u
    double kp = 0.0;
    double integral_Hz = 0.0;    // ω_i / 2π
    double target_Hz = 0.0;      // as asked
    double crossover_Hz = 0.0;   // the ω_c the design was tuned to (≤ target)
    std::vector<Notch> notches;
    double phase_margin_deg = 0.0, gain_margin_db = 0.0;  // infinite GM: +inf
    double hinf_S = 0.0;
    std::vector<std::string> warnings;
};

// plant: continuous, stable or with poles at the origin. Throws
// std::invalid_argument naming the field (plant, crossover_hz) for bad input
// or when no crossover meets the margins.
PiNotchDesign design_pi_notch(const Zpk& plant, double crossover_Hz, const PiNotchOptions& o = {});

}  // namespace piezoloop::design
