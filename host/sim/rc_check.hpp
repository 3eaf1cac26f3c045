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
#pragma once

#include <optional>
#include <string>

#include "analysis/rc_analysis.hpp"
#include "sim/scenario.hpp"

namespace piezoloop::sim {

// Empty when the case is not of that form (no RC, not PI feedback, not a
// shan_pi stage with input_per_V * amplifier gain == 1, no dynamics).
std::optional<design::RcAnalysis> rc_conditions(const Scenario& s, const CaseSpec& c, double reference_frequency_Hz);

}  // namespace piezoloop::sim
