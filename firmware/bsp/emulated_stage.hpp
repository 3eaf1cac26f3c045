// The stage of a board without converters: the controller's output drives
// the stage model of common/ (StageModel: DAC, amplifier, Hammerstein
// plant, sensor, ADC -- the host simulator's float stage), and the tick
// reads its latest reading back.
//
// The values cross between the pipeline and the model exactly as in
// host/sim (sim/loop_kernel.hpp), so an emulated board and
// `piezoloop sim --fidelity float` run the very same arithmetic:
//   y sample = position.to_sample<T>(reading / sensor gain)   (gain 1: the reading)
//   u_V      = voltage.to_physical(u sample)
// with the pipeline's SignalScales. Quantisation, if any, is the StageConfig's
// own (dac / adc bits), not a board converter.
//
// The conversions happen in step() and reset(), outside the controller's
// timed work: on a real board the tick reads a converter register, and the
// M3's soft-float conversion of a physical value would otherwise be counted
// as controller time (hundreds of instructions). The arithmetic is the same
// either way, so the log hashes do not depend on where it happens.
//
// Timing, as on a real board whose ADC is sampled at the tick: the tick
// reads the reading latched at the end of the previous period, computes,
// and writes u; step() then advances the stage by one sample with that u
// and latches the new reading. One sample of compute delay, y_0 = 0.
//
// Header-only and free of board code: the host builds the very same class
// to compute the self-test's expected log hash (tests/firmware/).
#pragma once

#include <cstdint>
#include <type_traits>

#include "piezoloop/plant.hpp"
#include "piezoloop/q31.hpp"
#include "piezoloop/sample.hpp"
#include "piezoloop/stage_model.hpp"
#include "piezoloop/status.hpp"

namespace piezoloop::fw {

// A stage of ideal parts around `plant` (no converter quantisation, unit
// amplifier and sensor, no bandwidths, no noise): the plant alone.
constexpr StageConfig ideal_stage(const PlantConfig& plant, float rate_Hz) {
    StageConfig c{};
    c.rate_Hz = rate_Hz;
    c.plant = plant;
    return c;
}

class EmulatedStage {
public:
    // Not concurrent with step(): call with the control timer stopped (or
    // masked). position / voltage: the pipeline's SignalScales.
    Status configure(const StageConfig& c, SignalScale position, SignalScale voltage) {
        if (const Status s = model_.configure(c); !s.ok()) return s;
        position_ = position;
        voltage_ = voltage;
        gain_ = c.sensor.gain;
        reset();
        return ok_status();
    }
    // Stage at rest: model states zero, command 0 V, next reading 0.
    void reset() {
        model_.reset();
        u_V_ = 0.0f;
        u_q31_ = Q31{};
        y_um_ = 0.0f;
        y_q31_ = position_.to_sample<Q31>(y_um_);
    }

    // The reading the tick uses, in the pipeline's sample type.
    template <class T>
    T position_sample() const {
        if constexpr (std::is_same_v<T, Q31>) return y_q31_;
        else return position_.to_sample<T>(y_um_);  // float: the physical value itself
    }
    // The tick's output; a Q31 command is converted to volts in step().
    template <class T>
    void command(T u) {
        if constexpr (std::is_same_v<T, Q31>) {
            u_q31_ = u;
            q31_command_ = true;
        } else {
            u_V_ = voltage_.to_physical(u);
        }
    }

    // One sample of physics with the last command; latches the reading.
    void step() {
        if (q31_command_) u_V_ = voltage_.to_physical(u_q31_);
        const float reading = model_.step(u_V_);
        y_um_ = gain_ == 1.0f ? reading : reading / gain_;
        if (q31_command_) y_q31_ = position_.to_sample<Q31>(y_um_);
    }

    float position_um() const { return y_um_; }
    float command_V() const { return u_V_; }
    const StageModel& model() const { return model_; }

private:
    StageModel model_{};
    SignalScale position_{1.0f};
    SignalScale voltage_{1.0f};
    float gain_ = 1.0f;
    float u_V_ = 0.0f;
    Q31 u_q31_{};
    bool q31_command_ = false;  // the tick runs the Q31 core: u_q31_ is the command
    float y_um_ = 0.0f;
    Q31 y_q31_{};
};

// The board tick's output phase against the emulated stage: reading in,
// Pipeline::output, command out (begin_tick / end_tick run around it in
// firmware/app/control_loop.cpp).
template <class T, class PipelineT>
inline void emulated_output(PipelineT& pipe, EmulatedStage& stage) {
    stage.command(pipe.output(stage.template position_sample<T>()));
}

// One whole control step against the emulated stage, as the host replays
// do it: reading in, pipeline tick, command out. The stage's step() follows
// separately (outside the controller's timed work).
template <class T, class PipelineT>
inline void emulated_control_step(PipelineT& pipe, EmulatedStage& stage) {
    stage.command(pipe.tick(stage.template position_sample<T>()));
}

}  // namespace piezoloop::fw
