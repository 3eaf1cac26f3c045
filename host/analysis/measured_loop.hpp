// The loop figures of a controller on a *measured* plant: margins and the
// sensitivity peak from the measured frequency response's lines, not from a
// fitted model (so a design is checked against what the stage did, with
// whatever the fit missed). Used by `piezoloop analyze measured-loop`.
//
// L_k = G_k K(jω_k) at each line (K evaluated at e^{jω ts} for a discrete
// controller); phase unwrapped along the lines from the principal value at
// the lowest. Crossings are located between neighbouring lines by linear
// interpolation on a log-frequency axis: of log|L| for a gain crossover
// (|L| = 1), of the unwrapped phase for a phase crossover (∠L = (2k+1)·180°);
// the other quantity is interpolated at the crossing. Conventions as
// margins.hpp: PM = 180° + ∠L at |L| = 1 (the smallest reported), GM =
// 1 / |L| at a phase crossover (the smallest |dB| reported).
//
// The figures are only as good as the line density: a mode between two
// lines is invisible, and ‖S‖ over the lines is a lower bound of ‖S‖∞.
// Warnings say when a crossing lies where neighbouring lines differ by more
// than 30° of phase or 6 dB (the interpolation there is coarse), and when no
// gain crossover lies inside the measured range.
#pragma once

#include <optional>
#include <string>
#include <vector>

#include "lti/lti.hpp"

namespace piezoloop::design {

struct MeasuredCrossing {
    double f_Hz = 0.0;
    double value = 0.0;  // PM in degrees (gain crossover) or GM in dB (phase crossover)
};

struct MeasuredLoop {
    std::vector<double> f_Hz;
    std::vector<cplx> loop;  // L at each line
    std::vector<double> phase_deg;  // ∠L unwrapped along the lines
    std::vector<MeasuredCrossing> gain_crossovers, phase_crossovers;  // ascending f
    std::optional<MeasuredCrossing> phase_margin;  // smallest PM
    std::optional<MeasuredCrossing> gain_margin;   // smallest |GM dB|
    double max_sensitivity = 0.0;                  // max |1 / (1 + L)| over the lines
    double max_sensitivity_Hz = 0.0;
    std::vector<std::string> warnings;
};

// f_Hz ascending, positive, one response per line; controller continuous
// (evaluated at jω) or discrete (at e^{jω ts}). Throws
// std::invalid_argument naming "frf" or "controller" for bad input.
MeasuredLoop measured_loop(const std::vector<double>& f_Hz, const std::vector<cplx>& plant, const Zpk& controller);

}  // namespace piezoloop::design
