// The servo application: the control tick runs in the timer interrupt, the
// main loop serves the binary link protocol (docs/protocol.md) on the
// console UART (on the STM32 also on the USB bulk endpoints, which mirror
// the console). Two images are built from this file, three on a board with
// converters for three axes:
//   servo.elf     starts the loop disarmed and serves the link;
//   selftest.elf  (PIEZOLOOP_SELFTEST_AUTORUN) runs the self-test once and
//                 exits with the number of failures (CI, QEMU);
//   servo_xyz.elf (PIEZOLOOP_SERVO_XYZ, STM32H743) serves three axes on the
//                 board's converters (app/servo_converter_axes.cpp).
//
// Boot (emulated boards): the emulation profile at kEmulationProfileAddress
// (common/piezoloop/emulation_profile.hpp), put there by QEMU's generic
// loader, sets the stage, the full scales and the loop rate:
//   valid    -> that stage at that rate, pipeline empty (the host configures it)
//   absent   -> the reference stage at 100 kHz, reference controller staged
//   invalid  -> the reference as if absent; the error (group, field,
//               message) goes to the semihosting console (QEMU's stdout/stderr,
//               never the UART), and status faults bit 8 (board fault 0) is set.
// A valid profile with the axes blob beside it (common/piezoloop/axes/
// emulation_axes_profile.hpp) is a stage of 2 or 3 coupled axes: the
// image then runs that many axes (app/servo_axes.cpp), up to the board's
// kSelfTestAxes; an invalid or too large one is reported the same way and
// the board runs the profile's first axis alone.
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
#include <cstdint>
#include <span>

#include "app/control_loop.hpp"
#include "app/selftest.hpp"
#include "app/selftest_cases.hpp"
#include "app/servo_axes.hpp"
#include "app/servo_service.hpp"
#include "board_config.hpp"
#include "bsp/bsp.hpp"
#include "piezoloop/axes/emulation_axes_profile.hpp"
#include "piezoloop/emulated_stage.hpp"
#include "piezoloop/emulation_profile.hpp"
#include "piezoloop/reference_stage.hpp"
#include "piezoloop/storage/param_storage.hpp"

#ifndef PIEZOLOOP_SELFTEST_AUTORUN
#define PIEZOLOOP_SELFTEST_AUTORUN 0
#endif
#ifndef PIEZOLOOP_SERVO_XYZ
#define PIEZOLOOP_SERVO_XYZ 0
#endif

namespace {

using namespace piezoloop;
using namespace piezoloop::fw;

struct Boot {
    bool reference_controller = true;  // no profile: the reference controller unless a stored set replaces it
    bool axes = false;                 // a valid axes blob: run the coupled axes
    EmulationProfile profile{};
};
Boot g_boot;

// ---- boot: the emulated boards' profile -------------------------------------

// RAM the loader wrote before reset; nothing in the image points there.
std::span<const uint8_t> loader_area(uint32_t address, std::size_t bytes) {
    const auto* area = reinterpret_cast<const uint8_t*>(uintptr_t{address});
    asm volatile("" : "+r"(area));
    return {area, bytes};
}

void note_rejected(const char* what, const Status& s) {
    service_loop().board_faults |= kFaultProfileInvalid;
    semihosting_note(what, s.group != nullptr ? s.group : "", s.group != nullptr ? "." : "", s.field);
    semihosting_note("  ", s.message);
}

// The pipeline, the stage and the rate from the profile (or the reference);
// false if nothing can run. With a valid axes blob only the profile is
// kept (g_boot): servo_axes builds the coupled axes.
bool start_servo(ControlLoop& loop) {
    PipelineSetup setup = pipeline_setup(board_analog());
    StageConfig stage = ideal_stage(reference::plant(), kLoopRate_Hz);
    g_boot = Boot{};
    if constexpr (!bsp::config::kHasConverters) {
        const std::span<const uint8_t> bytes = loader_area(kEmulationProfileAddress, kEmulationProfileMaxBytes);
        if (profile_present(bytes)) {
            EmulationProfile& p = g_boot.profile;
            if (const Status s = decode_profile(bytes, p); s.ok()) {
                setup = pipeline_setup(BoardAnalog{bsp::config::kHardLimits, p.position_full_scale_um,
                                                   p.voltage_full_scale_V},
                                       static_cast<float>(p.loop_rate_Hz));
                stage = p.stage;
                service_loop().rate_Hz = p.loop_rate_Hz;
                g_boot.reference_controller = false;
                semihosting_note("piezoloop: emulation profile loaded");
                const std::span<const uint8_t> axes =
                    loader_area(kEmulationAxesProfileAddress, kEmulationAxesProfileMaxBytes);
                if (axes_profile_present(axes)) {
                    if (const Status a = check_axes_profile(axes, p); a.ok()) {
                        g_boot.axes = true;
                        return true;
                    } else {
                        note_rejected("piezoloop: axes profile rejected, running its first axis alone: ", a);
                    }
                }
            } else {
                note_rejected("piezoloop: emulation profile invalid, running the reference stage: ", s);
            }
        }
    }
    loop.rebuild(setup);
    if constexpr (!bsp::config::kHasConverters) {
        if (!bsp::emulated_stage().configure(stage, setup.position, setup.voltage).ok()) return false;
    }
    return true;
}

// ---- the single-axis loop for the link service ------------------------------

uint32_t loop_ticks() { return control_loop().ticks(); }
bool loop_running() { return control_loop().running(); }
LoopStatus loop_status() { return control_loop().status(); }
bool loop_tripped() { return control_loop().pipeline().limiter().tripped(); }

bool restart_stage() {
    bsp::emulated_stage().reset();
    return true;
}

// What the link device needs from the board besides its pipeline.
link::DeviceHooks link_hooks() {
    link::DeviceHooks hooks;
    hooks.mask_tick = &mask_tick;
    hooks.storage = bsp::param_storage();
    return hooks;
}

}  // namespace

int app_main() {
    if constexpr (PIEZOLOOP_SELFTEST_AUTORUN) return run_selftest();
    service_loop() = ServiceLoop{};
#if PIEZOLOOP_SERVO_XYZ
    return run_servo_converter_axes(link_hooks());  // app/servo_converter_axes.cpp, in this image only
#endif
    ControlLoop& loop = control_loop();
    if (!start_servo(loop)) return 1;
    link::DeviceHooks hooks = link_hooks();
    if (g_boot.axes) return run_servo_axes(g_boot.profile, hooks);

    if constexpr (!bsp::config::kHasConverters) hooks.restart_stage = &restart_stage;
    // Before the stored set: its load masks the tick (mask_tick).
    ServiceLoop& svc = service_loop();
    svc.ticks = &loop_ticks;
    svc.running = &loop_running;
    svc.status = &loop_status;
    svc.tripped = &loop_tripped;
    BoardDevice& dev = loop.attach_device(device_info(), hooks);
    // The stored set, else the safe default: the reference controller
    // where there is no profile.
    const link::StorageState st = load_stored_set(dev);
    if (st != link::StorageState::kApplied && g_boot.reference_controller &&
        !loop.pipeline().stage(reference::params(true, true, false)).ok())
        return 1;
    if (!loop.start(svc.rate_Hz, 0, TickTiming::kControlOnly)) return 1;
    serve(dev);
}
