// The stage as commissioning measured it, as a scenario (configs/scenarios.md):
// the loop's rate, limits and full scales, the fitted linear model's dynamics
// (unit DC gain) after the hysteresis fitted to the measured loops (a PI
// model) or, without one, the static gain of the largest safety step (the
// frequency response's small amplitude sees the hysteresis's lower
// small-signal slope, which would not reach the range), the sensor's
// measured noise and reach, and the commissioned
// controller as its case. Commissioning predicts tracking on it (the
// candidates are compared there, not on the stage), and writes it as
// DIR/scenario.json so that `piezoloop sim` reproduces the commissioned loop.
#pragma once

#include <optional>
#include <string>

#include <nlohmann/json.hpp>

#include "commission/stage_access.hpp"
#include "lti/lti.hpp"

namespace piezoloop::commission {

struct IdentifiedStage {
    std::string name;             // the scenario's name
    std::string measured_on;      // StageAccess::describe()
    LoopFacts loop;
    measure::MeasureBounds bounds;
    design::Zpk model;            // continuous, u (V) -> y (µm), one tick of delay left out
    std::optional<PiModel> hysteresis;  // plain PI model, u (V) -> y (µm)
    double offset_um = 0.0;       // added to the PI model's output (its plays at rest): the reading's offset
    double gain_um_per_V = 0.0;   // static gain without a hysteresis
    double noise_um = 0.0;        // the sensor's RMS noise at rest
};

// Its cases: "open_loop" (the stage driven at its static gain) and, given a
// controller, "commissioned".
nlohmann::json identified_scenario_json(const IdentifiedStage& st, const std::optional<Controller>& controller);

}  // namespace piezoloop::commission
