// The 100 kHz control tick on a board: in the timer interrupt,
//   [link device: next streamed setpoint] -> pipeline.begin_tick (r, u_ff)
//   -> ADC read -> pipeline.output -> DAC write -> pipeline.end_tick (recorder)
// (on the emulated boards the reading and the command are physical values
// from and to the emulated stage: bsp/<board>/board_io.hpp control_io)
// then, on boards whose converters are an emulated stage, one sample of the
// plant model. Timed with the board's stopwatch (bsp.hpp), kept apart: the
// controller's work "ADC read to DAC write" (the budget, and the latency
// from sample to command), the whole controller tick (what bounds the loop
// rate), and the plant's sample (not the controller's). Timeliness is kept by a TickMonitor
// (tick_stats.hpp): late ticks and missed periods are counted.
//
// The pipeline lives in static storage (it is tens of KiB: two banks with
// their RC delay lines, and the recorder) and is rebuilt in place by
// rebuild() -- only while the tick is stopped. Everything else the main loop
// does with it while the tick runs goes through the pipeline's own
// tick-safe interface (stage / arm / disarm / set_setpoint / start_wave /
// recorder read), which hands changes over at a tick boundary.
#pragma once

#include <cstdint>

#include "app/control_config.hpp"
#include "app/core_sample.hpp"
#include "app/tick_stats.hpp"
#include "piezoloop/link/device.hpp"

namespace piezoloop::fw {

using BoardPipeline = FwPipeline<CoreSample>;
// The link's dispatcher on the board's pipeline (servo.elf).
using BoardDevice = link::Device<CoreSample, kRcCapacity, kRecChannels, kRecCapacity, kSetpointCapacity, kExcCapacity>;
static_assert(std::is_same_v<BoardDevice::PipelineType, BoardPipeline>);

// The board's analog side (bsp/<board>/board_config.hpp).
BoardAnalog board_analog();

// What the tick times. The self-test times every phase and the plant. The
// servo reports ADC read to DAC write only (the status' tick figures) and
// times only that span: on QEMU each stopwatch reading waits on SysTick
// edges, register reads that cost the emulator far more than the
// instructions they count.
enum class TickTiming : uint8_t { kEveryPhase, kControlOnly };

struct LoopStatus {
    uint32_t ticks = 0;
    WorkStats control{};  // ADC read to DAC write, steady ticks
    // The rest is timed with TickTiming::kEveryPhase only (empty otherwise).
    WorkStats whole{};    // the whole controller tick (link, three phases), steady ticks
    // The whole controller tick of ticks that reconfigure: a parameter set
    // swapped in, or the pipeline armed (its states reset; both happen in
    // begin_tick). Rare, and costlier: kept apart so the steady figures are
    // not hidden behind them.
    WorkStats reconfigure{};
    WorkStats plant{};    // the emulated stage's sample (zero on real converters)
    uint32_t late = 0;
    uint32_t missed = 0;
    bool running = false;
};

class ControlLoop {
public:
    // Fresh pipeline with the board's setup (or `setup`: an emulated
    // board's profile). Drops the link device. The tick must be stopped.
    BoardPipeline& rebuild();
    BoardPipeline& rebuild(const PipelineSetup& setup);
    BoardPipeline& pipeline() { return *pipe_; }
    bool built() const { return pipe_ != nullptr; }

    // The link device on the current pipeline; its on_tick() runs in every
    // tick right before the pipeline's. The tick must be stopped.
    BoardDevice& attach_device(const link::DeviceInfo& info, const link::DeviceHooks& hooks);
    BoardDevice* device() { return device_; }

    // Starts the tick at rate_Hz; after max_ticks ticks (0: never) the tick
    // stops the timer itself, so a run has an exact length. Statistics are
    // reset. False if the board cannot make that rate or nothing is built.
    bool start(uint32_t rate_Hz, uint32_t max_ticks, TickTiming timing = TickTiming::kEveryPhase);
    void stop();
    bool running() const;

    // Consistent snapshot (the tick is held off for the copy).
    LoopStatus status() const;
    // Ticks since start() (one aligned word, written by the tick only).
    uint32_t ticks() const { return __atomic_load_n(&ticks_, __ATOMIC_RELAXED); }

    // The interrupt handler (bsp::TickHandler).
    template <TickTiming kTiming>
    static void tick();

private:
    BoardPipeline* pipe_ = nullptr;
    BoardDevice* device_ = nullptr;
    // Set by start(), cleared by stop() or by the tick that ends a run. A
    // RAM flag: the main loop polls it (on QEMU a peripheral read per poll
    // would end every translation block).
    volatile bool running_ = false;
    uint32_t max_ticks_ = 0;
    uint32_t ticks_ = 0;
    WorkStats control_{};
    WorkStats whole_{};
    WorkStats reconfigure_{};
    WorkStats plant_{};
    uint32_t last_swaps_ = 0;
    bool last_armed_ = false;
    TickMonitor monitor_{};
};

ControlLoop& control_loop();

// Critical section against the tick (PRIMASK), for short copies only.
class TickLock {
public:
    TickLock() {
        asm volatile("mrs %0, primask\n\tcpsid i" : "=r"(primask_)::"memory");
    }
    ~TickLock() { asm volatile("msr primask, %0" ::"r"(primask_) : "memory"); }
    TickLock(const TickLock&) = delete;
    TickLock& operator=(const TickLock&) = delete;

private:
    uint32_t primask_;
};

}  // namespace piezoloop::fw
