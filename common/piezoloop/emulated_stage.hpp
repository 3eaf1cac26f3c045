// The stage of a board without converters: the controller's output drives
// the stage model (StageModel: DAC, amplifier, Hammerstein plant, sensor,
// ADC -- the host simulator's float stage), and the tick reads its latest
// reading back. The values pass between the pipeline and the model through
// the closed-loop stepper the simulator uses (loop_stepper.hpp), so an
// emulated board and `piezoloop sim --fidelity float` run the very same
// arithmetic. Quantisation, if any, is the StageConfig's own (dac / adc
// bits), not a board converter.
//
// Timing, as on a real board whose ADC is sampled at the tick: the tick
// reads the reading latched at the end of the previous period, computes,
// and commands u (output(), inside the controller's timed work); step()
// then advances the stage by one sample with that u and latches the new
// reading (outside the timed work: the sample-type conversions happen
// there). One sample of compute delay, y_0 = 0.
//
// The QEMU boards (and the STM32 in loopback) keep one of these behind
// their "converters" (firmware/bsp/); the host replays of the self-test
// build the very same class to compute the expected log hash
// (tests/firmware/).
#pragma once

#include "piezoloop/loop_stepper.hpp"
#include "piezoloop/plant.hpp"
#include "piezoloop/sample.hpp"
#include "piezoloop/stage_model.hpp"
#include "piezoloop/status.hpp"

namespace piezoloop {

// A stage of ideal parts around `plant` (no converter quantisation, unit
// amplifier and sensor, no bandwidths, no noise): the plant alone.
constexpr StageConfig ideal_stage(const PlantConfig& plant, float rate_Hz) {
    StageConfig c{};
    c.rate_Hz = rate_Hz;
    c.plant = plant;
    return c;
}

// T: the sample type of the controller the stage is wired to.
template <class T>
class EmulatedStage {
public:
    // Not concurrent with step(): call with the control timer stopped (or
    // masked). position / voltage: the pipeline's SignalScales.
    Status configure(const StageConfig& c, SignalScale position, SignalScale voltage) {
        if (const Status s = model_.configure(c); !s.ok()) return s;
        loop_ = LoopStepper<T>(position, voltage, c.sensor.gain);
        reset();
        return ok_status();
    }
    // Stage at rest: model states zero, command 0 V, next reading 0.
    void reset() {
        model_.reset();
        loop_.reset();
    }

    // The reading the tick uses, and the tick's command.
    T reading() const { return loop_.reading(); }
    void command(T u) { loop_.command(u); }
    // A board tick's output phase: reading in, Pipeline::output, command out
    // (begin_tick / end_tick run around it in firmware/app/control_loop.cpp).
    template <class PipelineT>
    void output(PipelineT& pipe) {
        loop_.output(pipe);
    }
    // A whole controller tick, as the host replays run it.
    template <class PipelineT>
    void tick(PipelineT& pipe) {
        loop_.tick(pipe);
    }

    // One sample of physics with the last command; latches the reading.
    void step() { loop_.step(model_); }

private:
    StageModel model_{};
    LoopStepper<T> loop_{};
};

}  // namespace piezoloop
