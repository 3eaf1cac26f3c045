// The servo application: the control tick runs in the timer interrupt, the
// main loop serves the binary link protocol (docs/protocol.md) on the
// console UART (on the STM32 also on the USB bulk endpoints, which mirror
// the console). Two images are built from this file:
//   servo.elf     starts the loop disarmed and serves the link;
//   selftest.elf  (PIEZOLOOP_SELFTEST_AUTORUN) runs the self-test once and
//                 exits with the number of failures (CI, QEMU).
//
// Boot (emulated boards): the emulation profile at kEmulationProfileAddress
// (common/piezoloop/emulation_profile.hpp), put there by QEMU's generic
// loader, sets the stage, the full scales and the loop rate:
//   valid    -> that stage at that rate, pipeline empty (the host configures it)
//   absent   -> the reference stage at 100 kHz, reference controller staged
//   invalid  -> the reference as if absent; the error (group, field,
//               message) goes to the semihosting console (QEMU's stdout/stderr,
//               never the UART), and status faults bit 8 (board fault 0) is set.
// Hard output limits are always the board's compiled-in ones.
//
// Then the stored parameter set (bsp::param_storage(): a flash sector on
// the STM32, a host file on the QEMU boards started with `emulate
// --storage FILE`) is validated and applied as a Load request would
// (link/device.hpp); it replaces the reference controller. A set that is
// corrupt, from another firmware version or rejected by validation is
// ignored: the board keeps its safe default (the reference controller, or
// the empty pipeline). Either way the loop boots disarmed, and the status'
// storage block says what happened and why. The storage is touched in the
// main loop only, never in the tick.
//
// After boot the UART carries nothing but link frames, starting with one
// 0x00 delimiter so a client's decoder starts in sync. Only a CPU fault
// prints text there (bsp/cortex-m/fault.cpp), and then the program ends.
#include <array>
#include <cstdint>
#include <span>

#include "app/control_loop.hpp"
#include "app/selftest.hpp"
#include "app/selftest_cases.hpp"
#include "board_config.hpp"
#include "bsp/bsp.hpp"
#include "bsp/cortex-m/semihosting.hpp"
#include "piezoloop/emulated_stage.hpp"
#include "piezoloop/emulation_profile.hpp"
#include "piezoloop/reference_stage.hpp"
#include "piezoloop/storage/param_storage.hpp"

#ifndef PIEZOLOOP_SELFTEST_AUTORUN
#define PIEZOLOOP_SELFTEST_AUTORUN 0
#endif
#ifndef PIEZOLOOP_VERSION
#define PIEZOLOOP_VERSION "0.0.0"
#endif

namespace {

using namespace piezoloop;
using namespace piezoloop::fw;

// Board fault bits of the status reply (TickStats::board_faults, shifted to
// faults bit 8 and up).
constexpr uint32_t kFaultProfileInvalid = 1u << 0;

struct Boot {
    uint32_t rate_Hz = kLoopRateInt_Hz;
    uint32_t board_faults = 0;
    bool reference_controller = true;  // no profile: the reference controller unless a stored set replaces it
};
Boot g_boot;

// ---- boot: the emulated boards' profile -------------------------------------

void semihosting_note(const char* a, const char* b = "", const char* c = "", const char* d = "") {
    if constexpr (!bsp::config::kHasConverters) {
        for (const char* s : {a, b, c, d})
            if (s != nullptr && s[0] != '\0') (void)bsp::semihosting::call(0x04, s);  // SYS_WRITE0
        (void)bsp::semihosting::call(0x04, "\n");
    }
}

// The pipeline, the stage and the rate from the profile (or the reference);
// false if nothing can run.
bool start_servo(ControlLoop& loop) {
    PipelineSetup setup = pipeline_setup(board_analog());
    StageConfig stage = ideal_stage(reference::plant(), kLoopRate_Hz);
    g_boot = Boot{};
    if constexpr (!bsp::config::kHasConverters) {
        // RAM the loader wrote before reset; nothing in the image points there.
        const auto* area = reinterpret_cast<const uint8_t*>(uintptr_t{kEmulationProfileAddress});
        asm volatile("" : "+r"(area));
        const std::span<const uint8_t> bytes(area, kEmulationProfileMaxBytes);
        if (profile_present(bytes)) {
            EmulationProfile p;
            if (const Status s = decode_profile(bytes, p); s.ok()) {
                setup = pipeline_setup(BoardAnalog{bsp::config::kHardLimits, p.position_full_scale_um,
                                                   p.voltage_full_scale_V},
                                       static_cast<float>(p.loop_rate_Hz));
                stage = p.stage;
                g_boot.rate_Hz = p.loop_rate_Hz;
                g_boot.reference_controller = false;
                semihosting_note("piezoloop: emulation profile loaded");
            } else {
                g_boot.board_faults |= kFaultProfileInvalid;
                semihosting_note("piezoloop: emulation profile invalid, running the reference stage: ",
                                 s.group != nullptr ? s.group : "", s.group != nullptr ? "." : "", s.field);
                semihosting_note("  ", s.message);
            }
        }
    }
    loop.rebuild(setup);
    if constexpr (!bsp::config::kHasConverters) {
        if (!bsp::emulated_stage().configure(stage, setup.position, setup.voltage).ok()) return false;
    }
    return true;
}

// The stored set, else the safe default: the reference controller where
// there is no profile. False if nothing can run.
bool apply_stored_set(BoardPipeline& pipe, BoardDevice& dev) {
    const link::StorageState st = dev.boot_from_storage();
    if (st != link::StorageState::kAbsent) {
        const link::StatusReply why = dev.make_status();
        semihosting_note("piezoloop: stored parameter set ", link::storage_state_name(st), " ", why.storage_field.data());
    }
    if (st == link::StorageState::kApplied || !g_boot.reference_controller) return true;
    return pipe.stage(reference::params(true, true, false)).ok();
}

// ---- link hooks ---------------------------------------------------------------

// Masks the tick interrupt (PRIMASK) around main-loop changes the tick
// reads. A masked section starts right after a tick has run, so it has a
// whole period before the next tick is due (plus half a period before a
// delayed tick counts as missed): StartWave's section configures the wave
// generator, which on the soft-float Cortex-M3 takes thousands of
// instructions.
uint32_t g_saved_primask = 0;
void mask_tick(bool masked) {
    if (masked) {
        ControlLoop& loop = control_loop();
        const uint32_t t = loop.ticks();
        while (loop.running() && loop.ticks() == t) {
        }
        uint32_t p;
        asm volatile("mrs %0, primask\n\tcpsid i" : "=r"(p)::"memory");
        g_saved_primask = p;
    } else {
        asm volatile("msr primask, %0" ::"r"(g_saved_primask) : "memory");
    }
}

bool restart_stage() {
    bsp::emulated_stage().reset();
    return true;
}

// The emulated boards' serial: fixed per image (they have no unique ID).
// A board with one (STM32) defines PIEZOLOOP_BOARD_UNIQUE_SERIAL and
// bsp::board_serial_number() in its board_config.hpp.
constexpr const char* board_serial() {
    const char* b = bsp::kBoardName;
    if (b[0] == 'q' && b[5] == 'm' && b[6] == '7') return "QEMU-M7-0001";
    if (b[0] == 'q' && b[5] == 'm' && b[6] == '3') return "QEMU-M3-0001";
    return "STM32H743-0001";
}

link::TickStats tick_stats(ControlLoop& loop) {
    const LoopStatus st = loop.status();
    link::TickStats t;
    t.overruns = st.late + st.missed;
    t.time_min = st.control.min;
    t.time_max = st.control.max;
    t.time_mean = static_cast<float>(st.control.mean_tenths()) / 10.0f;
    // Instructions on the QEMU boards (no time base), cycles on hardware.
    t.counter_Hz = bsp::config::kHasConverters ? static_cast<float>(bsp::config::kCpuClock_Hz) : 0.0f;
    t.board_faults = g_boot.board_faults;
    return t;
}

// LEDs: the heartbeat toggles every 0.5 s of ticks (so it stops when the
// loop stops), the fault LED shows a tripped output limiter.
void update_leds(ControlLoop& loop, uint32_t& last_toggle, bool& on) {
    const uint32_t t = loop.ticks();
    if (t - last_toggle >= g_boot.rate_Hz / 2) {
        on = !on;
        last_toggle = t;
        bsp::set_led(bsp::Led::kHeartbeat, on);
    }
    bsp::set_led(bsp::Led::kFault, loop.pipeline().limiter().tripped());
}

void send_frame(std::span<const uint8_t> frame) {
    bsp::console_write(reinterpret_cast<const char*>(frame.data()), frame.size());
}

[[noreturn]] void serve(ControlLoop& loop, BoardDevice& dev) {
    uint32_t last_toggle = 0;
    bool heartbeat = false;
    std::array<uint8_t, 64> rx{};
    for (;;) {
        update_leds(loop, last_toggle, heartbeat);
        std::size_t n = 0;
        char c = 0;
        while (n < rx.size() && bsp::console_read(c)) rx[n++] = static_cast<uint8_t>(c);
        if (n != 0) {
            dev.set_tick_stats(tick_stats(loop));  // fresh for a status request
            dev.receive(std::span<const uint8_t>(rx.data(), n), send_frame);
        }
        // Every pass, so log blocks stream as the recorder fills.
        dev.poll_log(send_frame);
    }
}

}  // namespace

int app_main() {
    if constexpr (PIEZOLOOP_SELFTEST_AUTORUN) return run_selftest();
    ControlLoop& loop = control_loop();
    if (!start_servo(loop)) return 1;
    link::DeviceInfo info;
    info.board = bsp::kBoardName;
    info.firmware_version = PIEZOLOOP_VERSION;
#ifdef PIEZOLOOP_BOARD_UNIQUE_SERIAL
    info.serial = bsp::board_serial_number();  // STM32: the unique ID, as the USB serial number
#else
    info.serial = board_serial();
#endif
    link::DeviceHooks hooks;
    hooks.mask_tick = &mask_tick;
    if constexpr (!bsp::config::kHasConverters) hooks.restart_stage = &restart_stage;
    hooks.storage = bsp::param_storage();
    BoardDevice& dev = loop.attach_device(info, hooks);
    if (!apply_stored_set(loop.pipeline(), dev)) return 1;
    if (!loop.start(g_boot.rate_Hz, 0)) return 1;
    const char sync = 0;  // a delimiter: the client's decoder starts clean
    bsp::console_write(&sync, 1);
    serve(loop, dev);
}
