// One closed-loop run of the control core against a simulated stage.
//
//   tick k:  y_k (µm, as the core's sample type) -> Pipeline<T>::tick -> u_k
//            u_k (V) -> stage.step: applied for one tick -> reading latched
//            -> y_{k+1} = reading / sensor gain
//
// The loop is stepped by the core's LoopStepper (common/piezoloop/
// loop_stepper.hpp), as on the emulated boards (emulated_stage.hpp) and in
// common/piezoloop/reference_run.hpp: one tick of compute delay, the
// command computed at tick k shows in the reading of tick k + 1. y_0 = 0 (the
// stage at rest before its first sample).
//
// Two fidelities of the same stage:
//   float   common/piezoloop/stage_model.hpp: everything in float at the loop
//           rate, linear parts as biquad cascades. The code the emulated
//           boards run, so host and board agree bit for bit.
//   double  sim/stage_double.hpp: continuous parts integrated in double at a
//           multiple of the loop rate (exact ZOH sub-steps).
// The pipeline (the controller) is the core in float or Q31 in both cases.
//
// log_hash: reference::LogHash (FNV-1a 64, common/piezoloop/reference_run.hpp)
// over the bit patterns of r, y, u of every tick from tick 0, in the core's
// sample type (Q31: the raw integers) -- the same fold as the firmware
// self-test, so a board running the same case must print the same hash.
#pragma once

#include <complex>
#include <cstdint>
#include <functional>
#include <string>
#include <vector>

#include "piezoloop/pipeline.hpp"
#include "piezoloop/stage_model.hpp"
#include "sim/carried_stage.hpp"
#include "sim/metrics.hpp"
#include "sim/stage_double.hpp"

namespace piezoloop::sim {

enum class Fidelity { kFloat, kDouble };
enum class SampleType { kFloat, kQ31 };

const char* to_string(Fidelity f);
const char* to_string(SampleType s);

// Delay-line capacity of the simulator's pipelines: RC periods up to 16384
// ticks (a 10 Hz reference at 100 kHz needs 10 000). Boards use less.
inline constexpr int kSimRcCapacity = 16384;

// A controller case made concrete: everything one run needs.
struct LoopModel {
    PipelineSetup setup{};
    PipelineParams params{};
    SampleType sample = SampleType::kFloat;
    StageConfig stage{};               // float fidelity (rate_Hz = setup.rate_Hz)
    DoubleStageConfig stage_double{};  // double fidelity
};

struct RunOptions {
    TrajectoryConfig wave{};       // sample_rate_Hz is overwritten with the loop rate
    std::vector<float> table;      // kSteps / kTable values (wave.table is pointed at them)
    uint64_t ticks = 0;
    // Steady-state window for the metrics (docs/models.md): [window_start, ticks).
    uint64_t window_start = 0;
    double window_midpoint_um = 0.0;  // the reference's (max + min) / 2
    // Per-period RMS of e over the whole run (growth of an unstable loop).
    uint64_t period_ticks = 0;        // 0: none
    // Ticks of the wave's approach (approach.hpp) before its first point:
    // the per-period RMS counts from its end (approach_ticks()).
    uint64_t approach_ticks = 0;
    Fidelity fidelity = Fidelity::kFloat;
    // Complex amplitude of r and y at this frequency over the window (0: off).
    double tone_Hz = 0.0;
    // Log every log_every-th tick from log_start on (0: no log).
    uint64_t log_start = 0;
    uint64_t log_every = 0;
    bool hash = true;              // compute log_hash (costs ~15 ns per tick)
    // Float fidelity: run on this stage from where an earlier run left it
    // (and leave it where this one ends) instead of from rest.
    CarriedStage* carried = nullptr;
    // Called now and then with the fraction done (from the running thread).
    std::function<void(double)> progress;
};

struct RunLog {
    std::vector<uint64_t> tick;
    // u_fb_V: volts, or µm with FeedforwardKind::kPiSeries (a correction of
    // the displacement command before the inverse).
    std::vector<float> r_um, y_um, u_V, v_piezo_V, x_um, u_ff_V, u_fb_V;
};

struct RunResult {
    uint64_t log_hash = 0;
    uint64_t ticks = 0;
    double simulated_s = 0.0;
    double wall_s = 0.0;
    double realtime_factor = 0.0;  // simulated seconds per wall second
    TrackingMetrics tracking{};    // over the window
    double hysteresis_pct = -1.0;  // over the window (negative: undefined)
    std::vector<double> period_e_rms_um;
    std::complex<double> tone_r{}, tone_y{};  // DFT bin of r and y over the window
    TripReason trip = TripReason::kNone;
    uint32_t clamped_samples = 0;
    RunLog log;
};

// Throws std::invalid_argument (naming the field) when the model or the
// options are rejected by the core's validation.
RunResult run_loop(const LoopModel& model, const RunOptions& options);

// The ticks the core's approach takes from the stage at rest (y_0 = 0), or
// from a carried stage's reading from_um, to the wave's first point in this
// model (0: the wave starts at once).
uint64_t approach_ticks(const LoopModel& model, const RunOptions& options, float from_um = 0.0f);
// Puts the approach in front of a planned run: the run, its window and its
// log (unless it starts at tick 0) move on by the approach's ticks, so they
// cover the same periods of the wave as without one (`piezoloop sim`, the
// scenario reports' experiments; a board's record does the same).
void make_room_for_approach(const LoopModel& model, RunOptions& options, float from_um = 0.0f);

}  // namespace piezoloop::sim
