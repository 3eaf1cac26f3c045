// `measure step` and `measure loops` against the simulator (issue 16): the
// scenario's stage and the core's pipeline stepped by the loop kernel every
// simulated run uses (sim/loop_kernel.hpp), as `measure frf` (frf_sim.hpp).
//
// Open loop the command is streamed tick by tick through the core's
// excitation at the command point, with amplitude 0 and the wanted command as
// its offset (the board path streams it the same way): the excitation is
// started with the tick's value and asked to stop at once, so it runs exactly
// that one tick (a stop request is taken after the tick's sample, pipeline.hpp
// excitation_phase) and the next tick's value can be started after it. No
// controller runs; the limiter (range, slew, hard limits) still acts last.
// Closed loop (step only) the case's controller follows a setpoint changed at
// the step tick.
#pragma once

#include <cstdint>
#include <functional>
#include <string>
#include <vector>

#include "measure/step_response.hpp"
#include "sim/scenario.hpp"

namespace piezoloop::measure {

// ---------------------------------------------------------------- step

struct StepRequest {
    bool closed = false;
    double step = 0.0;        // open: command step (V); closed: reference step (um)
    double from = 0.0;        // open: bias before the step (V); closed: setpoint before it (um)
    double duration_s = 0.1;  // recorded after the step; the level before it is held as long first
};

// Setpoints a closed loop may be asked for: the mean-slope image of the
// command limits, intersected with what the sensor's ADC can read and the
// core's position scale (um).
struct RangeUm {
    double min_um = 0.0, max_um = 0.0;
};
RangeUm closed_loop_range(const sim::Scenario& s);

struct StepPlan {
    uint64_t hold_ticks = 0;    // before the step (settles the level it starts from)
    uint64_t post_ticks = 0;    // recorded after the step
    uint64_t pre_record = 0;    // of the hold, recorded (for the initial value and the plot)
};

// Checks the request before anything runs; throws std::invalid_argument
// naming the option (--step-v, --step-um, --bias-v, --from-um, --duration-s)
// and the allowed range.
StepPlan plan_step(const sim::Scenario& s, const StepRequest& r);

struct StepRun {
    StepPlan plan;
    std::vector<double> time_s;       // t = 0 at the step tick
    std::vector<double> r_um, y_um, u_V;
    StepFigures figures;              // of y (um)
    uint32_t clipped_samples = 0;     // clamped or slew-limited, in the record
    std::string trip = "none";
    uint64_t log_hash = 0;
    double wall_s = 0.0;
    std::vector<std::string> warnings;
};

StepRun run_step_sim(const sim::Scenario& s, const sim::CaseSpec* case_spec, const StepRequest& r,
                     const std::function<void(double)>& progress = {});

// ---------------------------------------------------------------- loops

struct LoopsRequest {
    std::vector<double> amplitudes_V;  // peak-to-peak of each loop, above the base
    double base_V = 0.0;               // command the loops start from and return to
    double frequency_Hz = 1.0;
    int cycles = 2;                    // per amplitude; the last is measured
    std::string shape = "triangle";    // triangle | sine (1 - cos: starts at the base with zero slope)
};

struct LoopsPlan {
    uint64_t cycle_ticks = 0;
    uint64_t ticks = 0;  // all amplitudes, all cycles
};
LoopsPlan plan_loops(const sim::Scenario& s, const LoopsRequest& r);

struct LoopFigures {
    double amplitude_V = 0.0;
    double hysteresis_pct = -1.0;   // sim::hysteresis_pct: width at the input midpoint / output range
    double max_width_pct = -1.0;    // widest vertical gap between the branches / output range
    double y_min_um = 0.0, y_max_um = 0.0;
};

struct LoopsRun {
    LoopsPlan plan;
    std::vector<double> time_s, u_V, y_um;
    std::vector<double> amplitude_V;  // of the loop each sample belongs to
    std::vector<LoopFigures> loops;
    uint32_t clipped_samples = 0;
    std::string trip = "none";
    uint64_t log_hash = 0;
    double wall_s = 0.0;
    std::vector<std::string> warnings;
};

LoopsRun run_loops_sim(const sim::Scenario& s, const sim::CaseSpec* case_spec, const LoopsRequest& r,
                       const std::function<void(double)>& progress = {});

// Widest gap between the rising and the falling branch of one cycle, as a
// percentage of the output range: the branches are split at the input's
// extreme and compared at common input levels (linear interpolation).
// Negative if the cycle does not rise then fall.
double loop_max_width_pct(const std::vector<double>& input, const std::vector<double>& output);

}  // namespace piezoloop::measure
