// A simulated stage that carries on between runs, as a board's does: each
// run starts where the last one left it (its hysteresis's memory, its modes'
// motion, its reading) instead of from rest. Commissioning's simulated
// stages use it (commission/sim_stage), so that a prediction runs the
// sequence a board runs. Between two runs a board's loop is disarmed and its
// output ramps to the safe value at the slew limit (pipeline.hpp); rest()
// gives the carried stage the same.
#pragma once

#include <cstdint>

#include "piezoloop/limits.hpp"
#include "piezoloop/stage_model.hpp"

namespace piezoloop::sim {

struct CarriedStage {
    StageModel stage{};
    float reading_um = 0.0f;  // what the next tick reads
    float command_V = 0.0f;   // the last command applied
    bool started = false;     // false: the next run starts from rest

    // The disarmed loop between runs: the command ramps from the last one to
    // the safe value (0 V within [u_min, u_max]) at the slew limit, then holds
    // for hold_s; the stage is stepped all the while.
    void rest(const LimitsConfig& limits, float rate_Hz, float sensor_gain, double hold_s) {
        if (!started) return;
        const float safe = 0.0f < limits.u_min_V ? limits.u_min_V : (0.0f > limits.u_max_V ? limits.u_max_V : 0.0f);
        const float step = limits.slew_V_per_s > 0.0f ? limits.slew_V_per_s / rate_Hz : 1e30f;
        auto apply = [&](float u) {
            const float reading = stage.step(u);
            reading_um = sensor_gain == 1.0f ? reading : reading / sensor_gain;
        };
        for (float u = command_V; u != safe;) {
            u = u > safe ? (u - step > safe ? u - step : safe) : (u + step < safe ? u + step : safe);
            apply(u);
        }
        const auto hold = static_cast<uint64_t>(hold_s * static_cast<double>(rate_Hz));
        for (uint64_t k = 0; k < hold; ++k) apply(safe);
        command_V = safe;
    }
};

}  // namespace piezoloop::sim
