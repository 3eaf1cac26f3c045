// A compensator (r in µm -> u in V) as a scenario's `pi_compensator`
// feedforward writes it (configs/scenarios.md): what the scenario reader
// takes back into the same PiModel, float for float.
#pragma once

#include <nlohmann/json.hpp>

#include "piezoloop/pi_model.hpp"

namespace piezoloop::sim {

// kind, thresholds_um, weights_V_per_um, p0_V_per_um; input_offset_um when
// not 0; dead_zones (thresholds_um, weights) when the input map has any.
// The input gain is not written: the reader's compensator has gain 1.
nlohmann::json pi_compensator_json(const PiModel& c);

}  // namespace piezoloop::sim
