// `measure frf` against the simulator: the scenario's stage and
// the core's pipeline with its excitation (common/piezoloop/excitation.hpp),
// stepped by the loop kernel every simulated run uses (sim/loop_kernel.hpp),
// so the recording is the one a board running the same excitation makes.
// The plan and the analysis are frf_plan's, shared with the board path.
//
// Open loop: no controller, u = limits(bias + d). Closed loop: the case's
// controller holds the setpoint (the bias converted at the stage's mean
// slope) and d is added to its command, u = limits(controller + d); the
// estimate Ybar / Ubar is then still the plant's (frf_estimate.hpp).
#pragma once

#include <cstdint>
#include <functional>
#include <string>
#include <vector>

#include "measure/frf_plan.hpp"
#include "sim/carried_stage.hpp"
#include "sim/scenario.hpp"

namespace piezoloop::measure {

// Largest period the simulator's pipeline tabulates (the lowest multisine
// from_Hz is rate / this).
inline constexpr uint32_t kSimExcitationCapacity = 16384;

// plan_frf against the scenario's rate and limits.
FrfPlan plan_frf(const sim::Scenario& s, const FrfRequest& r);

// case_spec: the controller (closed loop) and any hysteresis override of the
// case (open loop); null: the scenario's stage, open loop. carried: the
// stage carried on from an earlier run (sim/carried_stage.hpp); null: from rest.
FrfRun run_frf_sim(const sim::Scenario& s, const sim::CaseSpec* case_spec, const FrfRequest& r,
                   const std::function<void(double)>& progress = {}, sim::CarriedStage* carried = nullptr);

}  // namespace piezoloop::measure
