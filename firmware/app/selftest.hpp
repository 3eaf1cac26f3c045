// The self-test on a board: every case of selftest_cases.hpp run by the
// 100 kHz interrupt against the emulated stage, one JSON line each, plus
// checks of what must be refused and of overrun counting. Returns the
// number of failures (0: all passed). Needs the tick stopped; leaves it
// stopped.
//
// Output (one JSON object per line, keys in this order):
//   {"board","name","sample","ticks","overruns","late","missed",
//    "<unit>_per_tick_min","<unit>_per_tick_mean","<unit>_per_tick_max",
//    "<unit>_resolution","plant_<unit>_per_tick_mean","plant_<unit>_per_tick_max",
//    "budget","within_budget","frames","gaps","tracking_valid",
//    "e_max_um","e_rms_um","u_max_abs_V","log_hash"}
// with <unit> "insn" on the QEMU boards and "cycles" on hardware, then
//   {"board","check":"<name>","ok":true|false, ...details}
// and finally
//   {"board","selftest":"done","cases":n,"checks":m,"failures":k}
#pragma once

namespace piezoloop::fw {

int run_selftest();

}  // namespace piezoloop::fw
