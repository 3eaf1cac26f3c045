// `piezoloop sim` on a stage of coupled axes (multi_axis_loop.hpp): one axis
// runs the reference wave (its approach from rest first), the others hold a
// setpoint; the metrics are every axis's tracking over the last period and
// the cross motion of the held axes.
#pragma once

#include <string>
#include <vector>

#include <nlohmann/json.hpp>

#include "sim/experiments.hpp"
#include "sim/multi_axis_loop.hpp"
#include "sim/sim_case.hpp"

namespace piezoloop::sim {

struct MultiAxisSimRequest {
    SimCaseRequest sim;              // case, trajectory, duration, sample, log (fidelity: float only)
    std::string axis;                // the driven axis's name
    std::vector<std::string> holds;  // "NAME=UM" per held axis, or "UM" for every held axis
    bool check_realisation = true;   // the notes' realisation check of each controller (seconds for slow poles)
    // Every axis's wave from tick 0, the driven one's approach beside the
    // others' (a board's `record --start-wave --every-axis`); else the
    // driven wave waits until the longest approach has ended.
    bool start_together = false;
};

struct MultiAxisSimPlan {
    CaseSpec case_spec;
    TrajectoryRequest trajectory;
    MultiAxisModel model;
    MultiAxisRunOptions options;
    uint64_t approach_ticks = 0;  // the longest of the axes' approaches, before the wave's first period
    uint64_t period_ticks = 0;
};

// Checks the request (naming the option: "--axis: a stage of axes x, y, z:
// choose one", "--hold-um: ...") and builds the case on the coupled stage.
MultiAxisSimPlan plan_multi_axis_sim(const Scenario& s, const MultiAxisSimRequest& r);

// The JSON `piezoloop sim` prints for the run.
nlohmann::json multi_axis_sim_summary(const Scenario& s, const MultiAxisSimRequest& r, const MultiAxisSimPlan& p,
                                      const MultiAxisRunResult& result);

}  // namespace piezoloop::sim
