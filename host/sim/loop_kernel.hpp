// The inner loop of a closed-loop simulation, header-only and built from the
// core alone, so that the simulator (sim/closed_loop.cpp) and the benchmark
// (bench/bench_sim.cpp) time exactly the same code.
//
//   tick k:  y_k -> Pipeline::tick -> u_k -> stage.step
//            -> reading latched -> y_{k+1} = reading / sensor gain
//
// The loop itself is the core's LoopStepper (common/piezoloop/
// loop_stepper.hpp), the one the emulated boards and the reference run step
// too: one tick of compute delay, y_0 = 0. This adds what the simulator
// wants around it: the log hash and a per-tick observer. Every placement of
// the inverse (feedforward or Shan2012's series) is the core's
// (FeedforwardKind), so a board running the same parameters computes the same.
#pragma once

#include <cstdint>

#include "piezoloop/loop_stepper.hpp"
#include "piezoloop/pipeline.hpp"
#include "piezoloop/reference_run.hpp"
#include "piezoloop/sample.hpp"
#include "piezoloop/stage_model.hpp"
#include "carried_stage.hpp"  // beside this file: bench_sim includes this header without host/ on its path

namespace piezoloop::sim {

struct TickView {
    uint64_t k;
    float r_um, y_um;  // reference and the reading the controller used
    float u_V;         // command applied to the stage during this tick
};

// One loop, one tick at a time.
template <class T, class PipelineT, class Stage>
class LoopKernel {
public:
    LoopKernel(PipelineT& pipe, Stage& stage, float sensor_gain, reference::LogHash* hash)
        : pipe_(pipe), stage_(stage), hash_(hash), pos_(pipe.setup().position), volt_(pipe.setup().voltage),
          loop_(pos_, volt_, sensor_gain) {}

    // Tick k; observe(const TickView&, const TickSignals<T>&, const Stage&)
    // is called after the stage has been stepped with u_k (so the stage's
    // piezo voltage and displacement are those of tick k).
    template <class Observer>
    void step(uint64_t k, Observer&& observe) {
        const T u = loop_.tick(pipe_);
        const TickSignals<T>& sig = pipe_.last();
        if (hash_) {
            hash_->add_sample(sig.r);
            // sig.y is the reading the tick used, taken from memory so that
            // the reading itself stays in a float register across the tick
            // (folding its bits kept it in an integer register, two
            // cross-domain moves on the loop's dependency chain: bench_sim
            // ~200x -> ~190x real time).
            hash_->add_sample(sig.y);
            hash_->add_sample(u);
        }
        loop_.step(stage_);
        observe(TickView{k, pos_.to_physical(sig.r), pos_.to_physical(sig.y), volt_.to_physical(u)}, sig, stage_);
    }

    // A stage carried on from an earlier run (sim/carried_stage.hpp): the
    // kernel's stage takes its state, the first tick reads its reading and
    // the pipeline knows it as its latest (a wave's approach starts there,
    // as on a board); carry_out leaves this run's end there. Null or not
    // started: from rest.
    void carry_in(const CarriedStage* c) {
        if (!c || !c->started) return;
        stage_ = c->stage;
        loop_.resume(c->reading_um);
        pipe_.join_at_reading(loop_.reading());
    }
    void carry_out(CarriedStage* c) const {
        if (!c) return;
        c->stage = stage_;
        c->reading_um = pos_.to_physical(loop_.reading());
        c->command_V = volt_.to_physical(loop_.last_command());
        c->started = true;
    }

private:
    PipelineT& pipe_;
    Stage& stage_;
    reference::LogHash* hash_;
    SignalScale pos_, volt_;
    LoopStepper<T> loop_;
};

// Runs `ticks` ticks from rest, or, with `carried`, from where that stage
// was left (its model and next reading, which the run updates). With
// `hash`, r, y, u of every tick (core sample type, u as the pipeline
// output) are folded into it.
template <class T, class PipelineT, class Stage, class Observer>
inline void run_ticks(PipelineT& pipe, Stage& stage, float sensor_gain, uint64_t ticks, reference::LogHash* hash,
                      Observer&& observe, CarriedStage* carried = nullptr) {
    LoopKernel<T, PipelineT, Stage> loop(pipe, stage, sensor_gain, hash);
    if constexpr (std::is_same_v<Stage, StageModel>) loop.carry_in(carried);
    for (uint64_t k = 0; k < ticks; ++k) loop.step(k, observe);
    if constexpr (std::is_same_v<Stage, StageModel>) loop.carry_out(carried);
}

}  // namespace piezoloop::sim
