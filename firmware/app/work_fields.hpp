// The measured work of a self-test line, in the board's work unit
// (instructions on the QEMU boards, cycles on hardware): the ADC-read-to-
// DAC-write span, the whole controller tick (the reading-independent half
// before the ADC read and the recorder after the DAC write included), the
// ticks that swapped a parameter set in, and the emulated plant. Board only:
// the host replay has no stopwatch.
#pragma once

#include "app/json_line.hpp"
#include "app/tick_stats.hpp"
#include "board_config.hpp"

namespace piezoloop::fw {

inline void add_work_fields(JsonLine& j, const WorkStats& control, const WorkStats& whole,
                            const WorkStats& reconfigure, const WorkStats& plant) {
    const char* unit = bsp::config::kWorkUnit;
    j.uint({unit, "_per_tick_min"}, control.min);
    j.fixed({unit, "_per_tick_mean"}, static_cast<double>(control.mean_tenths()) / 10.0, 1);
    j.uint({unit, "_per_tick_max"}, control.max);
    j.uint({unit, "_resolution"}, bsp::config::kStopwatchResolution);
    j.fixed({"tick_", unit, "_mean"}, static_cast<double>(whole.mean_tenths()) / 10.0, 1);
    j.uint({"tick_", unit, "_max"}, whole.max);
    j.uint("reconfigure_ticks", reconfigure.count).uint({"reconfigure_", unit, "_max"}, reconfigure.max);
    j.fixed({"plant_", unit, "_per_tick_mean"}, static_cast<double>(plant.mean_tenths()) / 10.0, 1);
    j.uint({"plant_", unit, "_per_tick_max"}, plant.max);
}

}  // namespace piezoloop::fw
