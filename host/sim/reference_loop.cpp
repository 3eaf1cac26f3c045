#include "reference_loop.hpp"

#include <memory>
#include <stdexcept>
#include <string>

#include "status_text.hpp"

namespace piezoloop::sim {

namespace {

// Appended step by step: GCC 12 at -O3 reports a false -Wrestrict on
// operator+ chains of std::string (GCC bug 105329).
std::string describe(const char* what, const Status& s) {
    std::string text(what);
    text += ": ";
    text += piezoloop::describe(s);
    return text;
}

}  // namespace

template <class T>
LoopLog run_reference_loop(const PipelineParams& params, const TrajectoryConfig& wave, int ticks, int logged) {
    // The pipeline holds two RC delay lines and a recorder: heap, not stack.
    auto pipe = std::make_unique<Pipeline<T>>(reference::setup());
    if (const Status s = pipe->stage(params); !s.ok()) throw std::invalid_argument(describe("params", s));
    if (const Status s = pipe->start_wave(wave); !s.ok()) throw std::invalid_argument(describe("wave", s));
    pipe->arm();
    HammersteinPlant plant;
    if (const Status s = plant.configure(reference::plant()); !s.ok())
        throw std::invalid_argument(describe("plant", s));
    const SignalScale pos = reference::setup().position, volt = reference::setup().voltage;
    LoopLog log;
    float y_um = 0.0f;
    for (int k = 0; k < ticks; ++k) {
        const T u = pipe->tick(pos.to_sample<T>(y_um));
        const float u_V = volt.to_physical(u);
        if (k >= ticks - logged) {
            log.r_um.push_back(pos.to_physical(pipe->last().r));
            log.y_um.push_back(y_um);
            log.u_V.push_back(u_V);
        }
        y_um = plant.step(u_V);
    }
    return log;
}

template LoopLog run_reference_loop<float>(const PipelineParams&, const TrajectoryConfig&, int, int);
template LoopLog run_reference_loop<Q31>(const PipelineParams&, const TrajectoryConfig&, int, int);

}  // namespace piezoloop::sim
