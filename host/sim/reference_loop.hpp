// Closed loop of a pipeline on the reference stage (common/piezoloop/
// reference_stage.hpp) with one tick of compute delay, logging the last
// samples in physical units. Used by `piezoloop demo` and the tests.
#pragma once

#include <vector>

#include "piezoloop/reference_stage.hpp"

namespace piezoloop::sim {

struct LoopLog {
    std::vector<double> r_um, y_um, u_V;
};

// Runs `ticks` ticks with wave `wave` and returns the last `logged` ticks.
// T is float or Q31 (the pipeline's sample type; the plant is float).
template <class T>
LoopLog run_reference_loop(const PipelineParams& params, const TrajectoryConfig& wave, int ticks, int logged);

}  // namespace piezoloop::sim
