// The closed loop between a controller and a stage, one sample at a time.
// Every closed-loop run of the project steps it: the simulator
// (host/sim/loop_kernel.hpp), the emulated boards and their host replays
// (emulated_stage.hpp) and the cross-platform reference run
// (reference_run.hpp), so they compute the same thing by construction.
//
//   tick k:  y_k = reading() -> controller (Pipeline::tick, or a board's
//            output phase) -> u_k -> command(u_k)
//   step():  the stage advances one sample with u_k; its reading divided
//            by the sensor gain is y_{k+1}
//
// One sample of compute delay, as on a board whose ADC is sampled at the
// tick; y_0 = 0 and u = 0 until the first command.
//
// The values cross between the controller's sample type T and physical
// units here and only here:
//   y sample = position.to_sample<T>(reading / sensor gain)  (gain 1: the reading)
//   u_V      = voltage.to_physical(u sample)
// with the pipeline's SignalScales (float: both are the value itself). Both
// conversions happen in step(), outside the controller's timed work: on a
// board the tick reads and writes converter registers, and the M3's
// soft-float conversion would otherwise be counted as controller time
// (hundreds of instructions). Where they happen does not change the
// arithmetic, so the log hashes do not depend on it.
//
// Stage: anything with `float step(float u_V)` returning the sensor's
// reading after one sample (StageModel, HammersteinPlant, the simulator's
// double-precision stage).
#pragma once

#include "piezoloop/sample.hpp"

namespace piezoloop {

template <class T>
class LoopStepper {
public:
    constexpr LoopStepper() = default;
    // position / voltage: the pipeline's SignalScales; sensor_gain: reading
    // per µm of displacement (non-zero; 1 for a stage that reads in µm).
    constexpr LoopStepper(SignalScale position, SignalScale voltage, float sensor_gain)
        : position_(position), voltage_(voltage), gain_(sensor_gain) {
        reset();
    }

    // At rest: reading 0, command 0.
    constexpr void reset() {
        y_ = position_.template to_sample<T>(0.0f);
        u_ = sample_zero<T>();
    }

    // A stage that is already running (the host simulator carrying one stage
    // across runs, as a board's carries on): the next tick reads y_um.
    constexpr void resume(float y_um) {
        y_ = position_.template to_sample<T>(y_um);
        u_ = sample_zero<T>();
    }
    // The last command, in the controller's sample type.
    constexpr T last_command() const { return u_; }
    // The reading the next tick uses, in the controller's sample type.
    constexpr T reading() const { return y_; }
    // The controller's output, applied to the stage by the next step().
    constexpr void command(T u) { u_ = u; }

    // A whole controller tick on the current reading; returns the command.
    template <class PipelineT>
    T tick(PipelineT& pipe) {
        u_ = pipe.tick(y_);
        return u_;
    }
    // A board's output phase (begin_tick() and end_tick() run around it).
    template <class PipelineT>
    void output(PipelineT& pipe) {
        u_ = pipe.output(y_);
    }

    // One sample of physics with the last command; latches the next reading.
    template <class Stage>
    void step(Stage& stage) {
        const float reading = stage.step(voltage_.to_physical(u_));
        const float y_um = gain_ == 1.0f ? reading : reading / gain_;
        y_ = position_.template to_sample<T>(y_um);
    }

private:
    SignalScale position_{1.0f};
    SignalScale voltage_{1.0f};
    float gain_ = 1.0f;
    T y_{};
    T u_{};
};

}  // namespace piezoloop
