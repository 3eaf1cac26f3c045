// The inputs every benchmark replays: one period of the reference loop
// (common/piezoloop/reference_stage.hpp) run in closed loop on the simulated
// stage, so a tick or a kernel sees the signals it sees in service (a 10 Hz,
// ±15 µm triangle with the tracking error, feedback and command that go with
// it), not a constant or white noise.
//
// Why the recorded loop runs WITHOUT the repetitive controller: closed on
// reference::plant(), reference::params(true, true, true) diverges (the RC
// correction doubles about every millisecond and the output reaches its
// ±10 V limits after ~15 ms; k_rc must come down to ~0.1 for the loop to
// settle; docs/benchmarks.md). A diverging loop is no "plausible y", so the trace is recorded
// with feedforward + feedback only, and the benchmarked pipeline (RC on)
// replays it open loop. Open loop, its near-integrator (pole at 0.1 Hz) would
// wind up on the RC's contribution over seconds, so every replay restarts the
// controller states from rest at the start of each trace period (outside the
// timed region): each period is then the first 0.1 s of a loop that starts
// at r = 0, u = 0.
#pragma once

#include <cstdio>
#include <cstdlib>
#include <memory>
#include <vector>

#include "piezoloop/reference_stage.hpp"

namespace bench {

// One period of the 10 Hz triangle at 100 kHz.
inline constexpr int kTraceTicks = 10000;

struct ReferenceTrace {
    // Per tick, physical units: y[k] is the measurement tick k sees and u[k]
    // the command it produces (the plant turns u[k] into y[k + 1]).
    std::vector<float> r_um, y_um, e_um, u_V;
};

[[noreturn]] inline void die(const char* what, const piezoloop::Status& s) {
    std::fprintf(stderr, "benchmark setup failed: %s: %s%s%s: %s\n", what, s.group ? s.group : "",
                 s.group ? "." : "", s.field ? s.field : "?", s.message ? s.message : "");
    std::exit(2);
}

inline void require(const char* what, const piezoloop::Status& s) {
    if (!s.ok()) die(what, s);
}

// The triangle starts at 0 µm going up (start phase 1/4), so the stage at
// rest sees no step; three periods settle the loop, the fourth is recorded.
inline piezoloop::TrajectoryConfig reference_triangle() {
    piezoloop::TrajectoryConfig t{};
    t.waveform = piezoloop::Waveform::kTriangle;
    t.amplitude_um = 15.0f;
    t.offset_um = 0.0f;
    t.frequency_Hz = 10.0f;
    t.sample_rate_Hz = piezoloop::reference::kRate_Hz;
    t.start_phase_cycles = 0.25f;
    return t;
}

inline const ReferenceTrace& reference_trace() {
    static const ReferenceTrace trace = [] {
        using namespace piezoloop;
        auto pipe = std::make_unique<Pipeline<float>>(reference::setup());
        require("trace pipeline", pipe->stage(reference::params(true, true, false)));
        pipe->arm();
        require("trace wave", pipe->start_wave(reference_triangle()));
        HammersteinPlant plant;
        require("trace plant", plant.configure(reference::plant()));
        ReferenceTrace t;
        const int settle = 3 * kTraceTicks;
        float y = 0.0f;
        for (int k = 0; k < settle + kTraceTicks; ++k) {
            const float u = pipe->tick(y);
            if (k >= settle) {
                t.r_um.push_back(pipe->last().r);
                t.y_um.push_back(y);
                t.e_um.push_back(pipe->last().e);
                t.u_V.push_back(u);
            }
            y = plant.step(u);
        }
        return t;
    }();
    return trace;
}

// A physical trace as samples of type T (Q31: normalised by `scale`).
template <class T>
std::vector<T> as_samples(const std::vector<float>& physical, piezoloop::SignalScale scale) {
    std::vector<T> out;
    out.reserve(physical.size());
    for (const float v : physical) out.push_back(scale.to_sample<T>(v));
    return out;
}

}  // namespace bench
