// The servo application: the control tick runs in the timer interrupt, the
// main loop serves the link. Two images are built from this file:
//   servo.elf     starts the loop on the reference parameters (disarmed) and
//                 serves single-letter commands on the console;
//   selftest.elf  (PIEZOLOOP_SELFTEST_AUTORUN) runs the self-test once and
//                 exits with the number of failures (CI, QEMU).
//
// Link service (minimal, until the link protocol issue; one letter per
// command, anything else ignored, each answered with one JSON line):
//   s  status: ticks, overruns, per-tick work min/mean/max, armed, wave, trip
//   a  arm          d  disarm
//   w  start the reference wave (10 Hz triangle, 15 µm)    x  stop it
//   z  wait 1000 ticks (10 ms), then answer
//   t  run the self-test (stops the loop, restarts it afterwards, disarmed)
//   h  list the commands
//   q  quit: stop the loop and exit with status 0
#include <cstdint>

#include "app/control_loop.hpp"
#include "app/json_line.hpp"
#include "app/selftest.hpp"
#include "app/selftest_cases.hpp"
#include "board_config.hpp"
#include "bsp/bsp.hpp"
#include "bsp/emulated_stage.hpp"

#ifndef PIEZOLOOP_SELFTEST_AUTORUN
#define PIEZOLOOP_SELFTEST_AUTORUN 0
#endif

namespace {

using namespace piezoloop;
using namespace piezoloop::fw;

JsonLine& begin(JsonLine& j) { return j.str("board", bsp::kBoardName); }

// The loop as it starts: reference controller, disarmed, stage at rest.
bool start_servo(ControlLoop& loop) {
    BoardPipeline& pipe = loop.rebuild();
    if (!bsp::config::kHasConverters && !bsp::emulated_stage().configure(reference::plant()).ok()) return false;
    if (!pipe.stage(reference::params(true, true, false)).ok()) return false;
    return loop.start(kLoopRateInt_Hz, 0);
}

void print_status(ControlLoop& loop, const char* reply) {
    const LoopStatus st = loop.status();
    BoardPipeline& pipe = loop.pipeline();
    const char* unit = bsp::config::kWorkUnit;
    JsonLine j;
    begin(j).str("reply", reply).boolean("running", st.running).uint("ticks", st.ticks);
    j.uint("overruns", st.late + st.missed).uint("late", st.late).uint("missed", st.missed);
    j.uint({unit, "_per_tick_min"}, st.control.min);
    j.fixed({unit, "_per_tick_mean"}, static_cast<double>(st.control.mean_tenths()) / 10.0, 1);
    j.uint({unit, "_per_tick_max"}, st.control.max);
    j.boolean("armed", pipe.armed()).boolean("wave", pipe.wave_running()).uint("swaps", pipe.swaps());
    j.str("trip", trip_reason_name(pipe.limiter().trip_reason()));
    j.fixed("u_V", static_cast<double>(pipe.setup().voltage.to_physical(pipe.last().u)), 4);
    j.fixed("y_um", static_cast<double>(pipe.setup().position.to_physical(pipe.last().y)), 4);
    j.flush();
}

void wait_ticks(ControlLoop& loop, uint32_t n) {
    const uint32_t start = loop.ticks();
    while (loop.running() && loop.ticks() - start < n) {
    }
}

// LEDs: the heartbeat toggles every 0.5 s of ticks (so it stops when the
// loop stops), the fault LED shows a tripped output limiter.
void update_leds(ControlLoop& loop, uint32_t& last_toggle, bool& on) {
    const uint32_t t = loop.ticks();
    if (t - last_toggle >= kLoopRateInt_Hz / 2) {
        on = !on;
        last_toggle = t;
        bsp::set_led(bsp::Led::kHeartbeat, on);
    }
    bsp::set_led(bsp::Led::kFault, loop.pipeline().limiter().tripped());
}

[[noreturn]] void serve(ControlLoop& loop) {
    uint32_t last_toggle = 0;
    bool heartbeat = false;
    for (;;) {
        update_leds(loop, last_toggle, heartbeat);
        char c = 0;
        if (!bsp::console_read(c)) {
            // The tick wakes the core at least once per period.
            bsp::wait_for_interrupt();
            continue;
        }
        BoardPipeline& pipe = loop.pipeline();
        JsonLine j;
        switch (c) {
            case 's': print_status(loop, "status"); break;
            case 'a': pipe.arm(); print_status(loop, "armed"); break;
            case 'd': pipe.disarm(); print_status(loop, "disarmed"); break;
            case 'w': {
                const Status s = pipe.start_wave(reference_wave());
                begin(j).str("reply", "wave").boolean("ok", s.ok()).str("field", s.field).flush();
                break;
            }
            case 'x': pipe.stop_wave(); print_status(loop, "wave_stopping"); break;
            case 'z': wait_ticks(loop, 1000); print_status(loop, "waited"); break;
            case 't': {
                loop.stop();
                const int failures = run_selftest();
                (void)bsp::set_loopback(false);  // back to the converters (hardware boards)
                const bool restarted = start_servo(loop);
                last_toggle = 0;
                begin(j).str("reply", "selftest").uint("failures", static_cast<uint64_t>(failures));
                j.boolean("servo_restarted", restarted).flush();
                break;
            }
            case 'h':
                begin(j).str("reply", "help").str("commands", "s status, a arm, d disarm, w wave, x stop wave, "
                                                              "z wait 10 ms, t self-test, q quit").flush();
                break;
            case 'q':
                loop.stop();
                begin(j).str("reply", "bye").flush();
                bsp::exit(0);
            default: break;  // whitespace, unknown letters
        }
    }
}

}  // namespace

int app_main() {
    if constexpr (PIEZOLOOP_SELFTEST_AUTORUN) return run_selftest();
    ControlLoop& loop = control_loop();
    JsonLine j;
    const bool ok = start_servo(loop);
    begin(j).str("reply", "ready").boolean("ok", ok).uint("rate_Hz", kLoopRateInt_Hz).flush();
    if (!ok) return 1;
    serve(loop);
}
