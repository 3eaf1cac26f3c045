// One closed-loop run of a scenario case as `piezoloop sim` makes it: the
// request (trajectory, duration, sample type, fidelity) planned into the
// built case and run options, and the summary JSON it prints. Shared by the
// command line (cli/cmd_sim.cpp) and the Python module (python/src/sim.cpp)
// so both give the same run, metrics and log hash for the same arguments.
#pragma once

#include <optional>
#include <string>

#include <nlohmann/json.hpp>

#include "sim/build_case.hpp"
#include "sim/experiments.hpp"
#include "sim/scenario.hpp"

namespace piezoloop::sim {

struct SimCaseRequest {
    std::string case_name;
    std::string trajectory = "triangle";  // triangle | sine
    double frequency_Hz = 10.0;
    double amplitude_um = 0.0;  // peak-to-peak; exactly one of the two amplitudes > 0
    double amplitude_V = 0.0;   // peak-to-peak piezo volts, at the stage's mean slope
    std::string offset;         // unipolar | bipolar; empty: the scenario's
    std::optional<double> midpoint_um;  // the wave's midpoint (overrides offset)
    double duration_s = 0.0;    // 0: two periods
    std::string fidelity = "float";  // float | double
    int substeps = 10;               // double fidelity
    std::string sample;              // float | q31; empty: the case's
    bool log = false;                // keep a log of the whole run
    int log_every = 0;               // with log: every N-th tick; 0: at most 200000 rows
};

struct SimCasePlan {
    CaseSpec case_spec;
    TrajectoryRequest trajectory;
    BuiltCase built;
    RunOptions options;
};

// The request's ranges and choices, as the command line's options name them
// (std::invalid_argument "--substeps: must be in [1, 10000] (got 0)").
void check_sim_request(const SimCaseRequest& r);

// The reference the request asks for (after check_sim_request):
// waveform, frequency, range, offset and whole periods of --duration-s.
TrajectoryRequest sim_trajectory(const Scenario& s, const SimCaseRequest& r);

// Checks the request (check_sim_request) and builds
// the case and the run options; the caller runs sim::run_loop(built.model,
// options), possibly after changing them (the CLI's --board-case).
SimCasePlan plan_sim_case(const Scenario& s, const SimCaseRequest& r);

// The JSON `piezoloop sim` prints for the run (without its --board-case entry).
nlohmann::json sim_case_summary(const Scenario& s, const SimCaseRequest& r, const SimCasePlan& p,
                                const RunResult& result);

}  // namespace piezoloop::sim
