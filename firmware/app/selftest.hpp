// The self-test on a board: every case of selftest_cases.hpp run by the
// 100 kHz interrupt against the emulated stage, then (QEMU boards) every
// multi-axis run (run_axes_cases below), then every
// board case QEMU's loader put into the RAM slots (common/piezoloop/
// board_case.hpp) at its own loop rate, one JSON line each, plus checks of
// what must be refused and of overrun counting. Returns the number of
// failures (0: all passed). Needs the tick stopped; leaves it stopped.
//
// Output (one JSON object per line, keys in this order):
//   {"board","name","sample","loop_rate_Hz","ticks","overruns","late","missed",
//    "<unit>_per_tick_min","<unit>_per_tick_mean","<unit>_per_tick_max",
//    "<unit>_resolution","tick_<unit>_mean","tick_<unit>_max",
//    "reconfigure_ticks","reconfigure_<unit>_max",
//    "plant_<unit>_per_tick_mean","plant_<unit>_per_tick_max",
//    "budget","within_budget","cpu_clock_Hz","loop_rate_max_Hz",
//    "frames","gaps","tracking_valid",
//    "e_max_um","e_rms_um","u_max_abs_V","log_hash"}
// with <unit> "insn" on the QEMU boards and "cycles" on hardware; for a
// case that cannot run (an invalid board case: name "board_case<slot>")
//   {"board","name","error":"<field>"[,"group"],"message"}
// then
//   {"board","check":"<name>","ok":true|false, ...details}
// and finally
//   {"board","selftest":"done","cases":n,"scenario_cases":s,"axes_cases":a,"checks":m,"failures":k}
#pragma once

namespace piezoloop::fw {

int run_selftest();

// The multi-axis case with 1 .. kSelfTestAxes axes (app/selftest_axes.cpp),
// one line each: the fields above (budget: the axes' ADC-to-DAC budget) and
// "axes", "<unit>_per_axis_mean", "tick_<unit>_per_axis_mean", "tick_budget",
// "within_tick_budget", per-axis tracking figures and hashes
// (app/selftest_axes_cases.hpp). The number of failed runs.
int run_axes_cases();

}  // namespace piezoloop::fw
