// The control tick of N coupled axes on an emulated board: the multi-axis
// self-test case (app/selftest_axes.cpp) and the servo image on a stage of
// coupled axes (app/servo_axes.cpp) both run it, in the timer interrupt:
//   [link device: next streamed setpoint]
//   begin_tick()  every axis's reading-independent half (matrices taken over)
//   ADC -> DAC    every reading in, MultiAxisPipeline::output (input matrix,
//                 N axis outputs, output matrix, channel limits), every
//                 command out: the budget span
//   end_tick()    the board's recorder and every axis's
// then the coupled stage's sample (the plant, apart). On a board with
// converters for its axes (the STM32H743's three-axis image) the converters
// stand where the emulated stage does: `Io` is then bsp::ConverterAxes,
// whose step() ends the tick's converter writes. Timed as
// ControlLoop::tick times the single-axis tick: three stopwatch spans, one
// per phase, so no span counts another's stopwatch (or, for the servo, the
// ADC -> DAC span alone: TickTiming); a tick that swaps a parameter set in
// or arms is counted apart as a reconfigure tick.
//
// One loop runs at a time; its state is one static object (the interrupt
// has no argument). Instantiate the tick in a translation unit built with
// -O2 (firmware/CMakeLists.txt), like control_loop.cpp.
#pragma once

#include <cstdint>

#include "app/control_loop.hpp"
#include "app/selftest_axes_cases.hpp"
#include "app/tick_stats.hpp"
#include "board_config.hpp"
#include "bsp/bsp.hpp"
#include "piezoloop/axes/emulated_coupled_stage.hpp"
#include "piezoloop/link/device.hpp"

namespace piezoloop::fw {

template <int N>
using AxesPipe = FwAxesPipeline<CoreSample, N>;
template <int N>
using AxesStage = EmulatedCoupledStage<CoreSample, N>;
template <int N>
using AxesDevice =
    link::Device<CoreSample, kRcCapacity, kRecChannels, kRecCapacity, kSetpointCapacity, kExcCapacity, N, true,
                 kBoardRecChannels>;

struct AxesLoopState {
    void* pipe = nullptr;
    void* stage = nullptr;
    void* device = nullptr;  // null: no link (the self-test)
    volatile bool running = false;
    uint32_t max_ticks = 0;
    uint32_t ticks = 0;
    WorkStats control{}, whole{}, reconfigure{}, plant{};
    TickMonitor monitor{};
    uint32_t last_swaps = 0;
    bool last_armed = false;
};
AxesLoopState& axes_loop();  // control_loop.cpp

template <int N>
uint32_t axes_swaps(const AxesPipe<N>& p) {
    uint32_t s = 0;
    for (int i = 0; i < N; ++i) s += p.axis(i).swaps();
    return s;
}

// Io: output(pipe) reads every axis, runs the pipeline's output and writes
// every command; step() runs after the tick (the emulated stage's sample).
template <int N, TickTiming kTiming, class Io>
void axes_tick() {
    constexpr bool kEveryPhase = kTiming == TickTiming::kEveryPhase;
    AxesLoopState& st = axes_loop();
    AxesPipe<N>& pipe = *static_cast<AxesPipe<N>*>(st.pipe);
    Io& stage = *static_cast<Io*>(st.stage);
    st.monitor.on_entry(bsp::timestamp());
    const bool armed = pipe.any_armed();

    uint32_t t_before = 0;
    if constexpr (kEveryPhase) t_before = bsp::stopwatch_start();
    if (st.device != nullptr) static_cast<AxesDevice<N>*>(st.device)->on_tick();
    pipe.begin_tick();
    uint32_t before = 0;
    if constexpr (kEveryPhase) before = bsp::stopwatch_elapsed(t_before);
    const uint32_t t_control = bsp::stopwatch_start();
    stage.output(pipe);
    const uint32_t work = bsp::stopwatch_elapsed(t_control);
    st.monitor.on_output(bsp::timestamp());
    uint32_t t_after = 0;
    if constexpr (kEveryPhase) t_after = bsp::stopwatch_start();
    pipe.end_tick();
    uint32_t whole = 0;
    if constexpr (kEveryPhase) whole = before + work + bsp::stopwatch_elapsed(t_after);

    const uint32_t s = axes_swaps<N>(pipe);
    const bool reconfigured = s != st.last_swaps || (armed && !st.last_armed);
    st.last_swaps = s;
    st.last_armed = armed;
    if (reconfigured) {
        if constexpr (kEveryPhase) st.reconfigure.add(whole);
    } else {
        st.control.add(work);
        if constexpr (kEveryPhase) st.whole.add(whole);
    }

    if constexpr (kEveryPhase) {
        const uint32_t t_plant = bsp::stopwatch_start();
        stage.step();
        st.plant.add(bsp::stopwatch_elapsed(t_plant));
    } else {
        stage.step();
    }

    ++st.ticks;
    if (st.max_ticks != 0u && st.ticks == st.max_ticks) {
        bsp::tick_timer_stop();
        st.running = false;
    }
}

// Starts the tick of `pipe` against `stage` (the emulated stage, or the
// board's converters) at rate_Hz (statistics reset); after max_ticks ticks
// (0: never) the tick stops the timer itself. False if the board cannot
// make that rate.
template <int N, class Io>
bool start_axes_loop(AxesPipe<N>& pipe, Io& stage, AxesDevice<N>* device, uint32_t rate_Hz,
                     uint32_t max_ticks, TickTiming timing = TickTiming::kEveryPhase) {
    AxesLoopState& st = axes_loop();
    st.pipe = &pipe;
    st.stage = &stage;
    st.device = device;
    st.max_ticks = max_ticks;
    st.ticks = 0;
    st.control = st.whole = st.reconfigure = st.plant = WorkStats{};
    st.last_swaps = axes_swaps<N>(pipe);
    st.last_armed = false;
    st.monitor.reset(bsp::config::kTimestamp_Hz / rate_Hz, bsp::config::kTimestampMask);
    st.running = true;
    const bsp::TickHandler handler = timing == TickTiming::kEveryPhase
                                         ? &axes_tick<N, TickTiming::kEveryPhase, Io>
                                         : &axes_tick<N, TickTiming::kControlOnly, Io>;
    if (bsp::tick_timer_start(rate_Hz, handler)) return true;
    st.running = false;
    return false;
}

// A consistent copy of the figures (the tick held off for the copy).
LoopStatus axes_loop_status();  // control_loop.cpp

}  // namespace piezoloop::fw
