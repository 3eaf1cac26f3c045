// The closed loop of a stage of two or three coupled axes: the core's
// MultiAxisPipeline (common/piezoloop/axes/multi_axis_pipeline.hpp, float or
// Q31) around its CoupledStage (axes/coupled_stage.hpp), one tick at a time.
//
//   tick k:  y_k[i] -> MultiAxisPipeline::tick -> channel commands u_k[i]
//            u_k (V) -> CoupledStage::step: every axis for one tick
//            -> readings latched -> y_{k+1}[i] = reading_i / sensor gain_i
//
// Per axis the arithmetic is LoopStepper's (common/piezoloop/
// loop_stepper.hpp): one tick of compute delay, y_0 = 0, u_V =
// voltage.to_physical(u), y = position.to_sample(reading / gain) (the
// division skipped for gain 1). With one axis, identity matrices and no
// coupling path this is the single-axis simulator (closed_loop.hpp) bit for
// bit, log hash included.
//
// log_hash: reference::LogHash over, per tick and axis in axis order, the
// axis's r and y (its pipeline's last() signals) and its channel's command
// (the DAC value, after the output matrix and the channel limits), in the
// core's sample type. One axis: the fold of closed_loop.hpp.
//
// Each axis is built with the single-axis machinery (build_case.hpp)
// against its own plant (plant.axes[i] alone); the coupled stage is
// coupled_stage_config's (coupled_stage_build.hpp).
#pragma once

#include <cstdint>
#include <string>
#include <vector>

#include "piezoloop/axes/coupled_stage.hpp"
#include "sim/build_case.hpp"
#include "sim/scenario.hpp"

namespace piezoloop::sim {

struct MultiAxisModel {
    std::vector<std::string> names;       // plant.axes' names ("x" for a single-axis plant)
    std::vector<BuiltCase> axes;          // each axis's controller (model.params) and setup, built alone
    CoupledStageConfig stage{};           // the coupled stage (float)
    SampleType sample = SampleType::kFloat;
    std::vector<std::vector<double>> output_matrix;  // empty: identity
    std::vector<std::vector<double>> input_matrix;   // empty: identity
    std::vector<double> input_offset_um;             // empty: zeros
};

// A scenario's case on its coupled stage. A single-axis scenario gives one
// axis and no path (the same stage and controller as build_case). Throws
// ScenarioError / std::invalid_argument naming the field.
MultiAxisModel build_multi_axis_case(const Scenario& s, const CaseSpec& c, const BuildOptions& o);

struct MultiAxisRunOptions {
    int driven = 0;                 // the axis that runs `wave`
    TrajectoryConfig wave{};        // sample_rate_Hz overwritten with the loop rate
    std::vector<float> hold_um;     // per axis: the setpoint the other axes hold (driven's entry unused)
    uint64_t ticks = 0;
    // The driven axis's wave is started before this tick (0: before the
    // first, as closed_loop.hpp starts it); the held axes' at once.
    uint64_t wave_tick = 0;
    uint64_t window_start = 0;      // metrics over [window_start, ticks)
    bool hash = true;
    uint64_t log_every = 0;         // 0: no log; else every N-th tick from tick 0
};

struct AxisRunResult {
    TrackingMetrics tracking{};     // r and y over the window (held axes: range 0, percentages 0)
    double position_min_um = 0.0, position_max_um = 0.0;  // its true position over the window
    TripReason trip = TripReason::kNone;
    uint32_t clamped_samples = 0;          // the axis's own limiter
    uint32_t channel_clamped_samples = 0;  // its channel after the output matrix
};

// Every logged tick: per axis (index [i][row]) r, y, the channel command,
// and the true position the stage's sensor of that axis reads.
struct MultiAxisLog {
    std::vector<uint64_t> tick;
    std::vector<std::vector<float>> r_um, y_um, u_V, p_um;
};

struct MultiAxisRunResult {
    uint64_t log_hash = 0;
    uint64_t ticks = 0;
    double wall_s = 0.0;
    std::vector<AxisRunResult> axes;
    MultiAxisLog log;
};

// Throws std::invalid_argument naming the field when the core refuses the
// model or the options.
MultiAxisRunResult run_multi_axis(const MultiAxisModel& m, const MultiAxisRunOptions& o);

// The ticks an axis's approach takes from rest to its wave's first value
// (the driven axis: `wave`; a held axis: its hold), as closed_loop.hpp's
// approach_ticks.
uint64_t multi_axis_approach_ticks(const MultiAxisModel& m, const MultiAxisRunOptions& o, int axis);

// The held axes' wave: their hold, constant (amplitude 0), at the driven
// wave's frequency.
TrajectoryConfig hold_wave(const TrajectoryConfig& driven, float hold_um);

// Cross motion of axis j: the peak-to-peak of its true position over the
// window as % of the driven axis's reference range.
double cross_motion_pct(const MultiAxisRunResult& r, int driven, int j);

}  // namespace piezoloop::sim
