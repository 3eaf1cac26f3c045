// The coupled stage (coupled_stage.hpp) behind a board's N sensors and N
// DACs, as EmulatedStage is the single-axis stage behind one of each: the
// multi-axis self-test case of the QEMU boards and its host replay build
// this class, so the two compute the same thing by construction.
//
// Per axis the values cross between the controller's sample type T and
// physical units exactly as LoopStepper does it (loop_stepper.hpp), in
// step(), outside the controller's timed work:
//   y_i sample = position_i.to_sample<T>(reading_i / sensor gain_i)
//   u_i (V)    = voltage_i.to_physical(u_i sample)
// One sample of compute delay, as on a board whose ADCs are sampled at the
// tick: the tick reads the readings latched by the previous step() and
// commands u (output()); step() advances the stage with that u. At rest:
// readings 0, commands 0.
#pragma once

#include <array>

#include "piezoloop/axes/coupled_stage.hpp"
#include "piezoloop/sample.hpp"
#include "piezoloop/status.hpp"

namespace piezoloop {

template <class T, int N>
class EmulatedCoupledStage {
    static_assert(N >= 1 && N <= kMaxStageAxes, "EmulatedCoupledStage<N>: 1 to 3 axes");

public:
    using Samples = std::array<T, N>;

    // c.axes must be N; position / voltage: each axis pipeline's scales.
    // Not concurrent with step(): the control timer stopped.
    Status configure(const CoupledStageConfig& c, const std::array<SignalScale, N>& position,
                     const std::array<SignalScale, N>& voltage) {
        if (c.axes != N) return error("axes", "must equal the number of controller axes");
        if (const Status s = stage_.configure(c); !s.ok()) return s;  // sensor gains non-zero among the rest
        position_ = position;
        voltage_ = voltage;
        for (int i = 0; i < N; ++i) gain_[static_cast<std::size_t>(i)] = c.axis[static_cast<std::size_t>(i)].sensor.gain;
        reset();
        return ok_status();
    }
    void reset() {
        stage_.reset();
        for (int i = 0; i < N; ++i) {
            y_[static_cast<std::size_t>(i)] = position_[static_cast<std::size_t>(i)].template to_sample<T>(0.0f);
            u_[static_cast<std::size_t>(i)] = sample_zero<T>();
        }
    }

    const Samples& readings() const { return y_; }
    const Samples& commands() const { return u_; }

    // A board tick's output phase: every reading in, the pipeline's
    // output(), every command out (begin_tick / end_tick run around it).
    template <class MultiPipelineT>
    void output(MultiPipelineT& pipe) {
        u_ = pipe.output(y_);
    }
    // A whole controller tick, as the host replay runs it.
    template <class MultiPipelineT>
    void tick(MultiPipelineT& pipe) {
        u_ = pipe.tick(y_);
    }

    // One sample of physics with the last commands; latches the readings.
    void step() {
        std::array<float, kMaxStageAxes> u_V{};
        std::array<float, kMaxStageAxes> reading{};
        for (int i = 0; i < N; ++i)
            u_V[static_cast<std::size_t>(i)] = voltage_[static_cast<std::size_t>(i)].to_physical(u_[static_cast<std::size_t>(i)]);
        stage_.step(u_V.data(), reading.data());
        for (int i = 0; i < N; ++i) {
            const std::size_t k = static_cast<std::size_t>(i);
            const float y_um = gain_[k] == 1.0f ? reading[k] : reading[k] / gain_[k];
            y_[k] = position_[k].template to_sample<T>(y_um);
        }
    }

    const CoupledStage& stage() const { return stage_; }

private:
    CoupledStage stage_{};
    std::array<SignalScale, N> position_{};
    std::array<SignalScale, N> voltage_{};
    std::array<float, N> gain_{};
    Samples y_{};
    Samples u_{};
};

}  // namespace piezoloop
