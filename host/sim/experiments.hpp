// The experiments of docs/models.md, 'Stages and scenarios', on a scenario: hysteresis loops over
// amplitudes, tracking over frequencies, closed-loop frequency response,
// steps, and the growth of an unstable loop. Each cell of a source's table
// is one closed-loop run; runs are independent and deterministic, so they
// are spread over worker threads.
#pragma once

#include <complex>
#include <functional>
#include <map>
#include <optional>
#include <string>
#include <vector>

#include "sim/build_case.hpp"
#include "sim/closed_loop.hpp"
#include "sim/scenario.hpp"

namespace piezoloop::sim {

// One reference trajectory and how long to run it.
struct TrajectoryRequest {
    Waveform waveform = Waveform::kTriangle;
    double frequency_Hz = 1.0;
    double range_um = 1.0;           // peak-to-peak
    bool unipolar = true;            // from 0 up, else centred on 0
    std::optional<double> midpoint_um;  // given: the wave's midpoint instead (sim --midpoint-um)
    int periods = 2;                 // the last one is the measured window
    double min_duration_s = 0.0;
    std::vector<double> steps_um;    // steps: the levels (waveform kSteps), each held hold_s
    double hold_s = 0.0;
};

// Run options for the request: ticks, the steady-state window (the last
// period), its midpoint, per-period RMS, and a log of the last period with
// at most `log_points` samples (0: none; whole_run: log the whole run).
RunOptions plan_run(double rate_Hz, const TrajectoryRequest& t, size_t log_points, bool whole_run);

struct CellResult {
    std::string case_name, case_label;
    double frequency_Hz = 0.0;
    double range_um = 0.0;    // reference peak-to-peak
    double amplitude_V = 0.0; // loops given in piezo volts: that amplitude (else 0)
    Fidelity fidelity = Fidelity::kFloat;
    RunResult run;
    std::string error;        // non-empty: the run could not be made
};

struct ExperimentResult {
    const ExperimentSpec* spec = nullptr;
    std::vector<CellResult> cells;  // case-major, then amplitude / frequency
};

struct ScenarioResult {
    const Scenario* scenario = nullptr;
    std::vector<ExperimentResult> experiments;
    std::vector<CellResult> fidelity_pairs;  // float, double, float, double, ...
    std::map<std::string, BuiltCase> built;  // per case (as built for its first run)
    double wall_s = 0.0;
};

struct ReproduceOptions {
    int threads = 2;
    int substeps = 10;             // double fidelity
    bool compare_fidelities = true;
    std::function<void(const std::string&)> log;  // progress messages
};

ScenarioResult run_scenario(const Scenario& s, const ReproduceOptions& o);

// Closed-loop gain y/r at the tone (complex), from a bode cell.
std::complex<double> tone_gain(const RunResult& r);

}  // namespace piezoloop::sim
