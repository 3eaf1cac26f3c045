// The self-test's multi-axis case (app/selftest_axes_cases.hpp) on the
// QEMU boards: 1 .. kSelfTestAxes axes, each run 0.2 s in the tick
// interrupt against the emulated coupled stage, one JSON line each.
//
// The tick is app/axes_loop.hpp's (the servo image runs the same one on a
// stage of coupled axes), without a link device.
//
// Built with -O2 like control_loop.cpp; not part of servo.elf (only
// run_selftest() calls it).
#include <array>
#include <cstdint>
#include <new>
#include <span>
#include <utility>

#include "app/axes_loop.hpp"
#include "app/control_loop.hpp"
#include "app/json_line.hpp"
#include "app/selftest.hpp"
#include "app/selftest_axes_cases.hpp"
#include "app/tick_stats.hpp"
#include "app/work_fields.hpp"
#include "board_config.hpp"
#include "bsp/bsp.hpp"

namespace piezoloop::fw {

namespace {

using T = CoreSample;
constexpr int kAxes = bsp::config::kSelfTestAxes;
static_assert(kAxes == 0 || kAxes == kAxesCount<T>, "the host replay runs kAxesCount<T> axes");

// One storage for the largest pipeline and one for its stage, both built
// in place for each count (raw storage: no static constructor, so nothing
// of this is kept in an image that never runs it).
constexpr int kLargest = kAxes >= 1 ? kAxes : 1;
alignas(AxesPipe<kLargest>) unsigned char g_pipe_storage[kAxes >= 1 ? sizeof(AxesPipe<kLargest>) : 1];
alignas(AxesStage<kLargest>) unsigned char g_stage_storage[kAxes >= 1 ? sizeof(AxesStage<kLargest>) : 1];

template <int N>
void drain(AxesPipe<N>& pipe, AxesLog<T, N>& log) {
    static std::array<typename AxesPipe<N>::AxisPipeline::RecorderType::Frame, 64> frames;
    for (int i = 0; i < N; ++i) {
        for (;;) {
            const std::size_t n = pipe.axis(i).recorder().read(std::span(frames));
            for (std::size_t k = 0; k < n; ++k) log.axis[static_cast<std::size_t>(i)].add(frames[k]);
            if (n < frames.size()) break;
        }
    }
}

// One run with N axes; 0 if it passed. Prints one line.
template <int N>
int run_axes(ControlLoop& loop) {
    constexpr uint32_t rate = kAxesRateInt_Hz<T>;
    constexpr uint32_t ticks = kAxesTicks<T>;
    const char* name = kAxesCaseNames[N - 1];
    loop.stop();
    auto* pipe = new (g_pipe_storage) AxesPipe<N>(axes_setup<N>(kAxesRate_Hz<T>));
    AxesStage<N>& stage = *new (g_stage_storage) AxesStage<N>();
    JsonLine j;
    j.str("board", bsp::kBoardName).str("name", name);
    static CoupledStageConfig stage_config;
    if (const Status s = prepare_axes_case<T, N>(*pipe, stage, stage_config); !s.ok()) {
        if (s.group != nullptr) j.str("group", s.group);
        j.str("error", s.field).str("message", s.message).flush();
        pipe->~AxesPipe<N>();
        return 1;
    }
    AxesLog<T, N> log = AxesLog<T, N>::make(*pipe);

    if (!start_axes_loop<N>(*pipe, stage, nullptr, rate, ticks)) {
        j.str("error", "tick_timer").str("message", "rate not possible").flush();
        pipe->~AxesPipe<N>();
        return 1;
    }
    // As selftest.cpp's drain_until_stopped: the check and the wait with
    // interrupts masked, so the last tick cannot slip in between.
    for (;;) {
        drain<N>(*pipe, log);
        asm volatile("cpsid i" ::: "memory");
        if (!axes_loop().running) {
            asm volatile("cpsie i" ::: "memory");
            break;
        }
        bool empty = true;
        for (int i = 0; i < N; ++i) empty = empty && pipe->axis(i).recorder().available() == 0;
        if (empty) bsp::wait_for_interrupt();
        asm volatile("cpsie i" ::: "memory");
    }
    drain<N>(*pipe, log);

    const AxesLoopState& st = axes_loop();
    const char* unit = bsp::config::kWorkUnit;
    const uint32_t overruns = st.monitor.late() + st.monitor.missed();
    const bool within = st.control.max <= bsp::config::kAxesTickBudget;
    const bool within_tick = st.whole.max <= bsp::config::kAxesWholeTickBudget;
    j.str("sample", kCoreSampleName).uint("axes", N).uint("loop_rate_Hz", rate);
    j.uint("ticks", st.ticks).uint("overruns", overruns).uint("late", st.monitor.late()).uint("missed", st.monitor.missed());
    add_work_fields(j, st.control, st.whole, st.reconfigure, st.plant);
    // Per axis: the figures over the axis count.
    j.fixed({unit, "_per_axis_mean"}, static_cast<double>(st.control.mean_tenths()) / 10.0 / N, 1);
    j.fixed({"tick_", unit, "_per_axis_mean"}, static_cast<double>(st.whole.mean_tenths()) / 10.0 / N, 1);
    j.uint("budget", bsp::config::kAxesTickBudget).boolean("within_budget", within);
    j.uint("tick_budget", bsp::config::kAxesWholeTickBudget).boolean("within_tick_budget", within_tick);
    j.uint("loop_rate_max_Hz", st.whole.max == 0 ? 0 : bsp::config::kCpuClock_Hz / st.whole.max);
    add_axes_log_fields(j, log);
    j.flush();

    const bool ok = st.ticks == ticks && st.control.count + st.reconfigure.count == st.ticks &&
                    st.whole.count == st.control.count && overruns == 0 && log.frames() == ticks &&
                    log.gaps() == 0;
    bool recorder_ok = true;
    for (int i = 0; i < N; ++i) recorder_ok = recorder_ok && pipe->axis(i).recorder().overruns() == 0;
    pipe->~AxesPipe<N>();
    return ok && recorder_ok ? 0 : 1;
}

template <int... I>
int run_counts(ControlLoop& loop, std::integer_sequence<int, I...>) {
    int failures = 0;
    ((failures += run_axes<I + 1>(loop)), ...);  // 1, 2, ... axes, in order
    return failures;
}

}  // namespace

int run_axes_cases() {
    if constexpr (kAxes < 1) {
        return 0;
    } else {
        return run_counts(control_loop(), std::make_integer_sequence<int, kAxes>{});
    }
}

}  // namespace piezoloop::fw
