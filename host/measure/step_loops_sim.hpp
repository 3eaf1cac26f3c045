// `measure step` and `measure loops` against the simulator: the
// scenario's stage and the core's pipeline stepped by the loop kernel every
// simulated run uses (sim/loop_kernel.hpp), as `measure frf` (frf_sim.hpp),
// with the excitations of step_loops_plan.hpp that a board runs too. Open
// loop no controller runs; closed loop (step only) the case's controller
// follows the reference.
#pragma once

#include <functional>

#include "measure/step_loops_plan.hpp"
#include "sim/carried_stage.hpp"
#include "sim/scenario.hpp"

namespace piezoloop::measure {

// The scenario's bounds: its rate, its limits, and for a closed loop the
// mean-slope image of the command limits intersected with what the sensor's
// ADC can read and the core's position scale (um).
MeasureBounds scenario_bounds(const sim::Scenario& s);

// `case_spec`: the controller (closed loop) and any hysteresis override and
// sample type; null: the scenario's stage, open loop, float.
// `carried`: the stage carried on from an earlier run (sim/carried_stage.hpp);
// null: from rest.
StepRun run_step_sim(const sim::Scenario& s, const sim::CaseSpec* case_spec, const StepRequest& r,
                     const std::function<void(double)>& progress = {}, sim::CarriedStage* carried = nullptr);

LoopsRun run_loops_sim(const sim::Scenario& s, const sim::CaseSpec* case_spec, const LoopsRequest& r,
                       const std::function<void(double)>& progress = {}, sim::CarriedStage* carried = nullptr);

}  // namespace piezoloop::measure
