#include "app/control_loop.hpp"

#include "app/axes_loop.hpp"

#include <new>

#include "board_config.hpp"
#include "board_io.hpp"
#include "bsp/bsp.hpp"

namespace piezoloop::fw {

namespace {

constexpr BoardAnalog kBoardAnalog{bsp::config::kHardLimits, bsp::config::kPositionFullScale_um,
                                   bsp::config::kVoltageFullScale_V};

alignas(BoardPipeline) unsigned char g_pipeline_storage[sizeof(BoardPipeline)];
alignas(BoardDevice) unsigned char g_device_storage[sizeof(BoardDevice)];
ControlLoop g_loop;
AxesLoopState g_axes_loop;

}  // namespace

BoardAnalog board_analog() { return kBoardAnalog; }
ControlLoop& control_loop() { return g_loop; }
AxesLoopState& axes_loop() { return g_axes_loop; }

LoopStatus axes_loop_status() {
    TickLock lock;
    const AxesLoopState& st = g_axes_loop;
    LoopStatus s;
    s.ticks = st.ticks;
    s.control = st.control;
    s.whole = st.whole;
    s.reconfigure = st.reconfigure;
    s.plant = st.plant;
    s.late = st.monitor.late();
    s.missed = st.monitor.missed();
    s.running = st.running;
    return s;
}

BoardPipeline& ControlLoop::rebuild() { return rebuild(pipeline_setup(kBoardAnalog)); }

BoardPipeline& ControlLoop::rebuild(const PipelineSetup& setup) {
    if (device_ != nullptr) device_->~BoardDevice();
    device_ = nullptr;
    if (pipe_ != nullptr) pipe_->~BoardPipeline();
    pipe_ = new (g_pipeline_storage) BoardPipeline(setup);
    return *pipe_;
}

BoardDevice& ControlLoop::attach_device(const link::DeviceInfo& info, const link::DeviceHooks& hooks) {
    if (device_ != nullptr) device_->~BoardDevice();
    device_ = new (g_device_storage) BoardDevice(*pipe_, info, hooks);
    return *device_;
}

bool ControlLoop::start(uint32_t rate_Hz, uint32_t max_ticks, TickTiming timing) {
    if (pipe_ == nullptr || rate_Hz == 0 || bsp::config::kTimestamp_Hz % rate_Hz != 0u) return false;
    stop();
    max_ticks_ = max_ticks;
    ticks_ = 0;
    control_ = WorkStats{};
    whole_ = WorkStats{};
    reconfigure_ = WorkStats{};
    plant_ = WorkStats{};
    last_swaps_ = pipe_->swaps();
    last_armed_ = false;
    monitor_.reset(bsp::config::kTimestamp_Hz / rate_Hz, bsp::config::kTimestampMask);
    running_ = true;
    const bsp::TickHandler handler = timing == TickTiming::kEveryPhase ? &ControlLoop::tick<TickTiming::kEveryPhase>
                                                                        : &ControlLoop::tick<TickTiming::kControlOnly>;
    if (bsp::tick_timer_start(rate_Hz, handler)) return true;
    running_ = false;
    return false;
}

void ControlLoop::stop() {
    bsp::tick_timer_stop();
    running_ = false;
}
bool ControlLoop::running() const { return running_; }

LoopStatus ControlLoop::status() const {
    TickLock lock;
    LoopStatus s;
    s.ticks = ticks_;
    s.control = control_;
    s.whole = whole_;
    s.reconfigure = reconfigure_;
    s.plant = plant_;
    s.late = monitor_.late();
    s.missed = monitor_.missed();
    s.running = running_;
    return s;
}

// The interrupt. The pipeline's tick in its three phases (pipeline.hpp):
// the reading-independent half first (on the STM32 it overlaps the ADC
// conversion the timer started at this period's edge), then ADC read ->
// output -> DAC write, the span the budget counts, then the recorder.
template <TickTiming kTiming>
void ControlLoop::tick() {
    constexpr bool kEveryPhase = kTiming == TickTiming::kEveryPhase;
    ControlLoop& loop = g_loop;
    BoardPipeline& pipe = *loop.pipe_;
    loop.monitor_.on_entry(bsp::timestamp());
    const bool armed = pipe.armed();

    // Three stopwatch spans, one per phase (a span nested in another would
    // count the inner stopwatch's own cost, on QEMU up to 80 instructions
    // of waiting for SysTick edges).
    uint32_t t_before = 0;
    if constexpr (kEveryPhase) t_before = bsp::stopwatch_start();
    if (BoardDevice* d = loop.device_) d->on_tick();
    pipe.begin_tick();
    uint32_t before = 0;
    if constexpr (kEveryPhase) before = bsp::stopwatch_elapsed(t_before);
    const uint32_t t_control = bsp::stopwatch_start();
    bsp::control_io<CoreSample>(pipe);
    const uint32_t work = bsp::stopwatch_elapsed(t_control);
    loop.monitor_.on_output(bsp::timestamp());
    uint32_t t_after = 0;
    if constexpr (kEveryPhase) t_after = bsp::stopwatch_start();
    pipe.end_tick();
    uint32_t whole = 0;
    if constexpr (kEveryPhase) whole = before + work + bsp::stopwatch_elapsed(t_after);

    const uint32_t swaps = pipe.swaps();
    const bool reconfigured = swaps != loop.last_swaps_ || (armed && !loop.last_armed_);
    loop.last_swaps_ = swaps;
    loop.last_armed_ = armed;
    if (reconfigured) {
        if constexpr (kEveryPhase) loop.reconfigure_.add(whole);
    } else {
        loop.control_.add(work);
        if constexpr (kEveryPhase) loop.whole_.add(whole);
    }

    if constexpr (kEveryPhase) {
        const uint32_t t_plant = bsp::stopwatch_start();
        bsp::emulated_stage_step();
        loop.plant_.add(bsp::stopwatch_elapsed(t_plant));
    } else {
        bsp::emulated_stage_step();
    }

    ++loop.ticks_;
    if (loop.max_ticks_ != 0u && loop.ticks_ == loop.max_ticks_) {
        bsp::tick_timer_stop();
        loop.running_ = false;
    }
}

}  // namespace piezoloop::fw
