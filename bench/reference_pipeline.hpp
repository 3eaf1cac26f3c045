// The pipeline under measurement: reference::setup() with
// reference::params(true, true, true) (15-operator inverse-PI feedforward,
// 3-section feedback, RC with N = 100, limits), armed, its recorder streaming
// r, y, e, u at every tick (continuous, decimation 1), fed with the reference
// trace (reference_trace.hpp) converted to the pipeline's sample type.
#pragma once

#include <cstdio>
#include <cstdlib>
#include <memory>
#include <vector>

#include "piezoloop/reference_stage.hpp"
#include "reference_trace.hpp"

namespace bench {

template <class T>
using RefPipeline = piezoloop::Pipeline<T, 1024, 4, 1024>;

// The reference trace as the pipeline's sample type.
template <class T>
struct Feed {
    std::vector<T> r, y;
};

template <class T>
const Feed<T>& feed() {
    static const Feed<T> f = [] {
        const ReferenceTrace& t = reference_trace();
        const piezoloop::SignalScale pos = piezoloop::reference::setup().position;
        return Feed<T>{as_samples<T>(t.r_um, pos), as_samples<T>(t.y_um, pos)};
    }();
    return f;
}

// Recorder streaming, `p` staged (it is swapped in by the first tick);
// restart() arms it. `record` false leaves the recorder idle (to measure
// what it costs).
template <class T>
std::unique_ptr<RefPipeline<T>> make_reference_pipeline(
    bool record = true, const piezoloop::PipelineParams& p = piezoloop::reference::params(true, true, true)) {
    using namespace piezoloop;
    auto pipe = std::make_unique<RefPipeline<T>>(reference::setup());
    typename RefPipeline<T>::RecorderType::Config rc{};
    rc.channels = {signal_index(SignalId::kR), signal_index(SignalId::kY), signal_index(SignalId::kE),
                   signal_index(SignalId::kU)};
    rc.decimation = 1;
    rc.mode = RecordMode::kContinuous;
    rc.trigger = TriggerMode::kImmediate;
    require("recorder", pipe->recorder().configure(rc));
    if (record && !pipe->recorder().arm()) {
        std::fprintf(stderr, "benchmark setup failed: recorder did not arm\n");
        std::exit(2);
    }
    require("stage", pipe->stage(p));
    return pipe;
}

// Start of a trace period (not to be timed): one tick disarmed (the output
// ramps one slew step towards 0 V; near r = 0 it is within a step of it),
// then the trace's first sample armed: the arming edge restarts the
// controller states from rest (see reference_trace.hpp). Two ticks, both
// recorded; returns the second one's output.
inline constexpr int kRestartTicks = 2;

template <class T>
T restart(RefPipeline<T>& pipe, const Feed<T>& f) {
    pipe.disarm();
    pipe.set_setpoint(f.r[0]);
    (void)pipe.tick(f.y[0]);
    pipe.arm();
    return pipe.tick(f.y[0]);
}

}  // namespace bench
