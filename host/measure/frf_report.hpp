// The JSON of a frequency-response measurement (`measure frf --out`, the
// Python package's measure_frf): the response and its uncertainty per line,
// the excitation, the method, the limiter's report and the warnings
// (docs/measurement.md, "frf.json"); `identify tf` reads it.
#pragma once

#include <optional>

#include <nlohmann/json.hpp>

#include "measure/frf_plan.hpp"

namespace piezoloop::measure {

// source: where the recording came from ({"kind": "board" | "simulator", ...});
// setpoint_um: the closed loop's setpoint where the caller knows it.
nlohmann::json frf_report(const FrfRequest& r, const FrfRun& run, const nlohmann::json& source,
                          std::optional<double> setpoint_um = std::nullopt);

}  // namespace piezoloop::measure
