// The RC stability conditions of docs/models.md, 'Repetitive control' (Shan2012 eq. 1-3, 15, 21) for a
// scenario case with PI(D) feedback, plug-in RC and a Shan-type PI
// hysteresis, evaluated by the design toolkit (analysis/rc_analysis) on the
// sampled linear loop the simulator runs:
//   L(z) = Gc(z) * k * G_zoh(z),
// Gc the PI in the controller's units, k the gain from the hysteresis
// model's output to the controller's error unit (output_um * error_per_um)
// with the hysteresis replaced by the identity on the model's input (the
// amplifier and the model's input scaling cancel: the model input is the
// command in volts), G_zoh the plant dynamics sampled with the DAC's hold
// (one tick: y[k+1] from u[k], so L carries no further delay).
//
// And for LTI feedback with the stage's PI inverse in series (u = P^-1(r +
// u_fb)), which linearises the hysteresis the loop sees: the inverse taken
// as exact, the loop is
//   L(z) = K(z) * error_per_um * G_zoh(z),
// K the controller discretised as the case does, G the amplifier's and the
// sensor's first-order lags and the dynamics (µm -> µm) sampled with the
// DAC's hold. The amplifier's lag, which runs between the inverse and the
// hysteresis, is taken as linear: the analysis holds for small signals about
// a branch of the loop, not for the large signals of saturation.
#pragma once

#include <optional>
#include <string>

#include "analysis/rc_analysis.hpp"
#include "sim/scenario.hpp"

namespace piezoloop::sim {

// Empty when the case is of neither form (no RC; not PI feedback on a
// shan_pi stage, nor LTI feedback with the PI inverse in series; no
// dynamics).
// The exact root check up to max_exact_delay_states (design::RcConfig).
std::optional<design::RcAnalysis> rc_conditions(const Scenario& s, const CaseSpec& c, double reference_frequency_Hz,
                                                int max_exact_delay_states = 4000);

}  // namespace piezoloop::sim
