// `measure step` and `measure loops`: requests, plans, results and
// the analysis of a recording, shared by the simulator (step_loops_sim.hpp)
// and a board (link/measure_session.hpp). Both run the core's excitation
// (common/piezoloop/excitation.hpp), so a board and the simulator make the
// same recording of the same stage:
//   open-loop step    kStep at the command: one period of 2 x hold ticks,
//                     offset the bias, amplitude the step; the command
//                     steps at tick `hold`, no controller runs;
//   closed-loop step  kStep at the reference: the loop holds `from`, and d
//                     adds the step at tick `hold`;
//   loops             per amplitude one kTriangle or kRaisedCosine at the
//                     command (offset the base, amplitude the loop's
//                     peak-to-peak, `cycles` periods), the amplitudes one
//                     after the other.
// The limiter (range, slew, hard limits) acts last in every case.
#pragma once

#include <cstdint>
#include <string>
#include <vector>

#include "measure/record_bound.hpp"
#include "measure/step_response.hpp"
#include "piezoloop/excitation.hpp"
#include "piezoloop/limits.hpp"

namespace piezoloop::measure {

// Setpoints a closed loop may be asked for (um).
struct RangeUm {
    double min_um = 0.0, max_um = 0.0;
};

// What a request is checked against: the loop rate, the command limits in
// effect, the setpoints a closed loop can hold, and whose they are for the
// messages ("scenario's", "board's").
struct MeasureBounds {
    double rate_Hz = 0.0;
    LimitsConfig limits{};
    RangeUm closed_range{};
    std::string whose;
};


// ---------------------------------------------------------------- step

struct StepRequest {
    bool closed = false;
    double step = 0.0;        // open: command step (V); closed: reference step (um)
    double from = 0.0;        // open: bias before the step (V); closed: setpoint before it (um)
    double duration_s = 0.1;  // recorded after the step; the level before it is held as long first
};

struct StepPlan {
    uint64_t hold_ticks = 0;    // before the step (settles the level it starts from)
    uint64_t post_ticks = 0;    // recorded after the step
    uint64_t pre_record = 0;    // of the hold, recorded (for the initial value and the plot)
};

// Checks the request before anything runs; throws std::invalid_argument
// naming the option (--step-v, --step-um, --bias-v, --from-um, --duration-s)
// and the allowed range.
StepPlan plan_step(const MeasureBounds& b, const StepRequest& r);

// The step as an excitation. Closed loop d is added to the setpoint the loop
// holds, `held_setpoint_um`: its offset brings the reference to `from`.
ExcitationConfig step_excitation(const StepPlan& p, const StepRequest& r, double rate_Hz, double held_setpoint_um);

struct StepRun {
    StepPlan plan;
    std::vector<double> time_s;       // t = 0 at the step tick
    std::vector<double> r_um, y_um, u_V;
    StepFigures figures;              // of y (um)
    uint32_t clipped_samples = 0;     // clamped or slew-limited
    std::string trip = "none";
    uint64_t log_hash = 0;            // r, y, u of every tick, as `sim --hash`
    double wall_s = 0.0;
    std::vector<std::string> warnings;
};

// From r, y, u of every tick of the step's excitation (2 x hold): the
// recorded window, the figures, and the warnings (clipped_samples and trip
// set first).
void analyse_step_run(const std::vector<double>& r_um, const std::vector<double>& y_um,
                      const std::vector<double>& u_V, double rate_Hz, StepRun& run);

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
    uint64_t amplitude_ticks = 0;  // one amplitude: cycles x cycle_ticks
    uint64_t ticks = 0;            // all amplitudes
};
LoopsPlan plan_loops(const MeasureBounds& b, const LoopsRequest& r);

// Amplitude j's excitation: `cycles` periods of the shape.
ExcitationConfig loop_excitation(const LoopsPlan& p, const LoopsRequest& r, std::size_t j, double rate_Hz);

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
    uint64_t log_hash = 0;            // 0: none (a board records each amplitude apart)
    double wall_s = 0.0;
    std::vector<std::string> warnings;
};

// From u and y of every tick of each amplitude's excitation (u[j], y[j]: its
// cycles): the (u_k, y_k+1) pairs, the figures of each amplitude's last cycle,
// the warnings (clipped_samples and trip set first).
void analyse_loops_run(const LoopsRequest& r, double rate_Hz, const std::vector<std::vector<double>>& u_V,
                       const std::vector<std::vector<double>>& y_um, LoopsRun& run);

// Widest gap between the rising and the falling branch of one cycle, as a
// percentage of the output range: the branches are split at the input's
// extreme and compared at common input levels (linear interpolation).
// Negative if the cycle does not rise then fall.
double loop_max_width_pct(const std::vector<double>& input, const std::vector<double>& output);

}  // namespace piezoloop::measure
