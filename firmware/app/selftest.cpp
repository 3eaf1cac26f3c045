#include "app/selftest.hpp"

#include <array>
#include <cstdint>
#include <span>
#include <type_traits>

#include "app/control_loop.hpp"
#include "app/json_line.hpp"
#include "app/selftest_cases.hpp"
#include "app/selftest_report.hpp"
#include "app/work_fields.hpp"
#include "board_config.hpp"
#include "bsp/bsp.hpp"
#include "piezoloop/board_case.hpp"
#include "piezoloop/emulated_stage.hpp"

namespace piezoloop::fw {

// What the host promises when it writes a board case (board_case.hpp) must
// be what this firmware is: the QEMU boards' hard limits and RC delay line.
static_assert(kRcCapacity >= kEmulatedBoardRcCapacity);
static_assert(bsp::config::kHasConverters ||
              (bsp::config::kHardLimits.u_min_V == kEmulatedBoardHardLimits.u_min_V &&
               bsp::config::kHardLimits.u_max_V == kEmulatedBoardHardLimits.u_max_V &&
               bsp::config::kHardLimits.slew_max_V_per_s == kEmulatedBoardHardLimits.slew_max_V_per_s));

namespace {

using Frame = BoardPipeline::RecorderType::Frame;

std::array<Frame, 64> g_frames;

JsonLine& begin(JsonLine& j) { return j.str("board", bsp::kBoardName); }

bool same_analog(const BoardAnalog& a, const BoardAnalog& b) {
    return a.hard.u_min_V == b.hard.u_min_V && a.hard.u_max_V == b.hard.u_max_V &&
           a.hard.slew_max_V_per_s == b.hard.slew_max_V_per_s &&
           a.position_full_scale_um == b.position_full_scale_um && a.voltage_full_scale_V == b.voltage_full_scale_V;
}

// Drains whatever the recorder holds into the accumulator.
void drain(BoardPipeline& pipe, LogAccumulator<CoreSample>& acc) {
    for (;;) {
        const std::size_t n = pipe.recorder().read(std::span<Frame>(g_frames));
        for (std::size_t i = 0; i < n; ++i) acc.add(g_frames[i]);
        if (n < g_frames.size()) return;
    }
}

// Main loop while the tick runs: drain, and wait for the next interrupt
// when there is nothing to do. The check and the wait are done with
// interrupts masked so the last tick (which stops the timer) cannot slip in
// between them and leave WFI waiting forever; a masked pending interrupt
// still wakes WFI.
void drain_until_stopped(ControlLoop& loop, BoardPipeline& pipe, LogAccumulator<CoreSample>& acc) {
    for (;;) {
        drain(pipe, acc);
        asm volatile("cpsid i" ::: "memory");
        if (!loop.running()) {
            asm volatile("cpsie i" ::: "memory");
            break;
        }
        if (pipe.recorder().available() == 0) bsp::wait_for_interrupt();
        asm volatile("cpsie i" ::: "memory");
    }
    drain(pipe, acc);
}

// Waits for a run started with a tick limit to end (nothing to drain).
void wait_until_stopped(ControlLoop& loop) {
    for (;;) {
        asm volatile("cpsid i" ::: "memory");
        if (!loop.running()) {
            asm volatile("cpsie i" ::: "memory");
            return;
        }
        bsp::wait_for_interrupt();
        asm volatile("cpsie i" ::: "memory");
    }
}

// One case: the pipeline rebuilt with `setup` (null: the board's own), the
// tick at rate_Hz for c.ticks ticks, one JSON line. 0 if it passed.
int run_case(ControlLoop& loop, const SelfTestCase& c, const PipelineSetup* setup = nullptr,
             uint32_t rate_Hz = kLoopRateInt_Hz) {
    BoardPipeline& pipe = setup != nullptr ? loop.rebuild(*setup) : loop.rebuild();
    EmulatedStage<CoreSample>& stage = bsp::emulated_stage();
    JsonLine j;
    if (const Status s = prepare_case<CoreSample>(pipe, stage, c); !s.ok()) {
        begin(j).str("name", c.name).str("error", s.field).str("message", s.message).flush();
        return 1;
    }
    LogAccumulator<CoreSample> acc(pipe.setup().position, pipe.setup().voltage, c.metric_start_tick);
    if (!loop.start(rate_Hz, c.ticks)) {
        begin(j).str("name", c.name).str("error", "tick_timer").str("message", "rate not possible").flush();
        return 1;
    }
    drain_until_stopped(loop, pipe, acc);
    const LoopStatus st = loop.status();

    const uint32_t overruns = st.late + st.missed;
    const bool within = st.control.max <= bsp::config::kTickBudget;
    begin(j).str("name", c.name).str("sample", kCoreSampleName).uint("loop_rate_Hz", rate_Hz);
    j.uint("ticks", st.ticks).uint("overruns", overruns).uint("late", st.late).uint("missed", st.missed);
    add_work_fields(j, st.control, st.whole, st.reconfigure, st.plant);
    j.uint("budget", bsp::config::kTickBudget).boolean("within_budget", within);
    // The highest loop rate the whole controller tick allows at the board's
    // CPU clock: one instruction per cycle on the QEMU boards (their nominal
    // 25 MHz), measured cycles on hardware.
    j.uint("cpu_clock_Hz", bsp::config::kCpuClock_Hz);
    j.uint("loop_rate_max_Hz", st.whole.max == 0 ? 0 : bsp::config::kCpuClock_Hz / st.whole.max);
    add_log_fields(j, c, acc);
    j.flush();

    const bool ok = st.ticks == c.ticks && st.control.count + st.reconfigure.count == st.ticks && st.whole.count == st.control.count && overruns == 0 && acc.frames() == c.ticks && acc.gaps() == 0 &&
                    pipe.recorder().overruns() == 0;
    return ok ? 0 : 1;
}

// ---- scenario cases (board cases in RAM) ----------------------------------

// The slot's case, decoded (static: it is a few KiB).
BoardCase g_board_case;

// Runs the board case in slot i if there is one: -1 if the slot is empty,
// else the number of failures (an invalid case prints an error line naming
// the field and counts as one).
int run_board_case(ControlLoop& loop, int i) {
    // RAM the loader wrote before reset; nothing in the image points there.
    const auto* area = reinterpret_cast<const uint8_t*>(
        uintptr_t{kBoardCaseAddress + static_cast<uint32_t>(i) * kBoardCaseSlotBytes});
    asm volatile("" : "+r"(area));
    const std::span<const uint8_t> bytes(area, kBoardCaseSlotBytes);
    if (!board_case_present(bytes)) return -1;
    const char slot_names[kBoardCaseSlots][12] = {"board_case0", "board_case1", "board_case2"};
    Status s = decode_board_case(bytes, g_board_case);
    const char* name = s.ok() ? g_board_case.name.data() : slot_names[i];
    const link::SampleFormat core =
        std::is_same_v<CoreSample, Q31> ? link::SampleFormat::kQ31 : link::SampleFormat::kFloat32;
    if (s.ok() && g_board_case.sample != core)
        s = error("sample", "the case was built for the other core (float on qemu-m7, q31 on qemu-m3)");
    if (!s.ok()) {
        JsonLine j;
        begin(j).str("name", name).str("error", s.field);
        if (s.group != nullptr) j.str("group", s.group);
        j.str("message", s.message).flush();
        return 1;
    }
    const PipelineSetup setup = scenario_setup(g_board_case, bsp::config::kHardLimits);
    return run_case(loop, scenario_case(g_board_case), &setup, g_board_case.profile.loop_rate_Hz);
}

// ---- checks ------------------------------------------------------------

struct Checks {
    int count = 0;
    int failures = 0;
    void report(JsonLine& j, bool ok) {
        j.boolean("ok", ok).flush();
        ++count;
        if (!ok) ++failures;
    }
};

// The hard limits are the board's, compiled in; the pipeline was built with
// them and a parameter set cannot widen them.
void check_limits(ControlLoop& loop, Checks& checks) {
    BoardPipeline& pipe = loop.rebuild();
    const HardLimits& hard = pipe.setup().hard;
    {
        JsonLine j;
        begin(j).str("check", "hard_limits_compiled_in");
        j.fixed("hard_u_min_V", static_cast<double>(hard.u_min_V), 3)
            .fixed("hard_u_max_V", static_cast<double>(hard.u_max_V), 3)
            .fixed("hard_slew_V_per_s", static_cast<double>(hard.slew_max_V_per_s), 0);
        checks.report(j, same_analog(board_analog(), BoardAnalog{hard, pipe.setup().position.full_scale,
                                                                 pipe.setup().voltage.full_scale}) &&
                             (bsp::config::kHasConverters || same_analog(board_analog(), kEmulatedAnalog)));
    }
    const PipelineParams good = reference::params(true, true, false);
    const bool staged = pipe.stage(good).ok();
    // Swap it in with exactly one tick (the stage sits at rest).
    bsp::emulated_stage().reset();
    const bool one_tick = loop.start(kLoopRateInt_Hz, 1);
    wait_until_stopped(loop);
    {
        JsonLine j;
        begin(j).str("check", "swap_at_tick_boundary").uint("swaps", pipe.swaps());
        checks.report(j, staged && one_tick && pipe.swaps() == 1 && !pipe.swap_pending() &&
                             pipe.params().sos_count == good.sos_count);
    }
    {
        PipelineParams wide = good;
        wide.limits.u_max_V = hard.u_max_V + 5.0f;
        const Status s = pipe.stage(wide);
        JsonLine j;
        begin(j).str("check", "limits_above_hard_refused").str("field", s.field).str("message", s.message);
        checks.report(j, !s.ok() && !pipe.swap_pending() && pipe.params().limits.u_max_V == good.limits.u_max_V);
    }
    {
        PipelineParams bad = good;
        bad.sos_count = kMaxControllerSections + 1;
        const Status s = pipe.stage(bad);
        JsonLine j;
        begin(j).str("check", "invalid_set_refused").str("field", s.field).str("message", s.message);
        checks.report(j, !s.ok() && !pipe.swap_pending() && pipe.params().sos_count == good.sos_count);
    }
}

// A rate the board cannot sustain must show up as overruns, not vanish.
void check_overruns(ControlLoop& loop, Checks& checks) {
    constexpr uint32_t kTicks = 200;
    BoardPipeline& pipe = loop.rebuild();
    const bool prepared = prepare_case<CoreSample>(pipe, bsp::emulated_stage(), kSelfTestCases[0]).ok();
    const bool started = loop.start(bsp::config::kOverrunTestRate_Hz, kTicks);
    wait_until_stopped(loop);
    const LoopStatus st = loop.status();
    JsonLine j;
    begin(j).str("check", "overruns_counted").uint("rate_Hz", bsp::config::kOverrunTestRate_Hz);
    j.uint("ticks", st.ticks).uint("overruns", st.late + st.missed).uint("late", st.late).uint("missed", st.missed);
    checks.report(j, prepared && started && st.ticks == kTicks && st.late + st.missed >= kTicks);
}

}  // namespace

int run_selftest() {
    ControlLoop& loop = control_loop();
    loop.stop();
    const bool loopback = bsp::set_loopback(true);
    int failures = loopback ? 0 : 1;
    for (const SelfTestCase& c : kSelfTestCases) failures += run_case(loop, c);
    failures += run_axes_cases();
    int scenario_cases = 0;
    if constexpr (!bsp::config::kHasConverters) {
        for (int i = 0; i < kBoardCaseSlots; ++i) {
            const int r = run_board_case(loop, i);
            if (r < 0) continue;
            ++scenario_cases;
            failures += r;
        }
    }
    Checks checks;
    check_limits(loop, checks);
    check_overruns(loop, checks);
    failures += checks.failures;
    JsonLine j;
    begin(j).str("selftest", "done").uint("cases", kSelfTestCaseCount).uint("scenario_cases", static_cast<uint64_t>(scenario_cases));
    j.uint("axes_cases", static_cast<uint64_t>(bsp::config::kSelfTestAxes));
    j.uint("checks", checks.count);
    j.uint("failures", static_cast<uint64_t>(failures)).flush();
    return failures;
}

}  // namespace piezoloop::fw
