// The self-test: its cases, how one is set up, and what is computed from
// the recorded log. Shared by the firmware (app/selftest.cpp, which runs a
// case in the tick interrupt) and the host (tests/firmware/
// host_selftest.cpp, which runs the same steps in a plain loop), so that the
// two log hashes can only differ if the core computes differently.
//
// Reference cases (compiled in, every board; 0.2 s = 20 000 ticks at
// 100 kHz each, the reference stage of common/piezoloop/reference_stage.hpp
// as the emulated plant, a 10 Hz triangle of 15 µm amplitude):
//   reference_all_blocks  reference::all_blocks_params(): inverse PI
//                         (15 operators), 3-section feedback, RC (N = 100)
//                         in the loop, limits, recorder. The budget case.
//                         Its RC's Q is cut off at 200 Hz: with the
//                         published Q (~7 kHz) the RC is unstable in this
//                         loop, whose closed-loop phase passes 90° near
//                         240 Hz (reference_stage.hpp), and the run diverged
//                         (float into the ±10 V limits, Q31 into its RC's
//                         full scale: the cores parted). Now a stable loop
//                         that tracks (e_max ~0.20 µm, both cores).
//   reference_ff_fb       reference::params(true, true, false): the same
//                         without RC, a stable loop; its tracking figures
//                         are the reference ones (e_max ~0.23 µm).
// Scenario cases (QEMU boards): board cases (common/piezoloop/
// board_case.hpp) that `piezoloop sim ... --board-case FILE` wrote for one
// scenario run each and QEMU's loader put into RAM: the scenario's stage,
// loop rate and full scales, its controller (limits clipped to the board's
// hard limits), its reference and length. scenario_case() turns one into a
// SelfTestCase; its log hash must equal the simulator's, its tracking
// figures are over the simulator's window (the last reference period).
// tests/CMakeLists.txt (fw_selftest_<board>) and docs/boards.md, "Self-test",
// say which cases run.
//
// Tracking metrics over the recorded frames from tick metric_start_tick on
// (reference cases: kMetricSkipTicks, the start transient excluded as in
// reference_run.hpp):
//   e = r - y in the sample type, converted to µm; e_max_um = max |e|,
//   e_rms_um = sqrt(mean e^2) (sum in double). u_max_abs_V: max |u| over
//   all frames (must stay within the hard limits).
// log_hash: LogHash (FNV-1a 64) over the bit patterns of r, y, u of every
// recorded frame, in tick order (Q31: the raw integers) -- the fold of
// `piezoloop sim --hash`.
#pragma once

#include <cstdint>

#include "app/control_config.hpp"
#include "piezoloop/board_case.hpp"
#include "piezoloop/emulated_stage.hpp"
#include "piezoloop/reference_run.hpp"
#include "piezoloop/reference_stage.hpp"

namespace piezoloop::fw {

inline constexpr uint32_t kCaseTicks = 20000;        // 0.2 s at 100 kHz
inline constexpr uint32_t kMetricSkipTicks = 2000;   // 20 ms start transient

struct SelfTestCase {
    const char* name;
    PipelineParams params;
    StageConfig stage;  // the emulated plant; its rate_Hz is the loop rate
    TrajectoryConfig wave;
    uint32_t ticks;
    uint32_t metric_start_tick;  // tracking figures over [this, ticks)
    bool tracking_valid;         // false: the loop is known not to track (see above)
};

constexpr TrajectoryConfig reference_wave() {
    TrajectoryConfig w{};
    w.waveform = Waveform::kTriangle;
    w.amplitude_um = 15.0f;
    w.frequency_Hz = 10.0f;
    w.sample_rate_Hz = kLoopRate_Hz;
    return w;
}

inline constexpr SelfTestCase kSelfTestCases[] = {
    {"reference_all_blocks", reference::all_blocks_params(), ideal_stage(reference::plant(), kLoopRate_Hz),
     reference_wave(), kCaseTicks, kMetricSkipTicks, true},
    {"reference_ff_fb", reference::params(true, true, false), ideal_stage(reference::plant(), kLoopRate_Hz),
     reference_wave(), kCaseTicks, kMetricSkipTicks, true},
};
inline constexpr int kSelfTestCaseCount = static_cast<int>(sizeof(kSelfTestCases) / sizeof(kSelfTestCases[0]));

// The analog side of the emulated boards (and of the host replay): the
// reference stage's full scales, the same as reference::setup().
inline constexpr BoardAnalog kEmulatedAnalog{reference::setup().hard, reference::setup().position.full_scale,
                                             reference::setup().voltage.full_scale};

// A board case as a self-test case. The wave's table (if any) points into
// `bc`, which must live until prepare_case() has started the wave (the
// generator copies it).
inline SelfTestCase scenario_case(const BoardCase& bc) {
    return SelfTestCase{bc.name.data(), bc.params,           bc.profile.stage, board_case_wave(bc),
                        bc.ticks,       bc.metric_start_tick, true};
}

// The pipeline setup of a board case on a board with hard limits `hard`:
// the profile's full scales and loop rate.
constexpr PipelineSetup scenario_setup(const BoardCase& bc, const HardLimits& hard) {
    return pipeline_setup(BoardAnalog{hard, bc.profile.position_full_scale_um, bc.profile.voltage_full_scale_V},
                          static_cast<float>(bc.profile.loop_rate_Hz));
}

// After a fresh pipeline and with the tick stopped: parameters staged (they
// swap in at the first tick), recorder armed on {r, y, u, e}, the case's
// stage at rest, pipeline armed, wave started -- the order in which the
// simulator (host/sim/closed_loop.cpp) starts a run.
template <class T, class PipelineT>
Status prepare_case(PipelineT& pipe, EmulatedStage<T>& stage, const SelfTestCase& c) {
    if (const Status s = pipe.stage(c.params); !s.ok()) return s;
    if (const Status s = pipe.recorder().configure(log_recorder_config<T>()); !s.ok()) return s;
    if (!pipe.recorder().arm()) return error("recorder", "arm refused");
    if (!(c.stage.rate_Hz == pipe.setup().rate_Hz)) return in_group("stage", error("rate_Hz", "must equal the loop rate"));
    if (const Status s = stage.configure(c.stage, pipe.setup().position, pipe.setup().voltage); !s.ok()) return s;
    pipe.arm();
    if (const Status s = pipe.start_wave(c.wave); !s.ok()) return s;
    return ok_status();
}

// Consumes recorded frames in order: log hash, tracking metrics, and gaps
// (frames the recorder dropped, or ticks missing from the sequence).
template <class T>
class LogAccumulator {
public:
    LogAccumulator(SignalScale position, SignalScale voltage, uint32_t metric_start_tick)
        : position_(position), voltage_(voltage), metric_start_(metric_start_tick) {}

    template <class Frame>
    void add(const Frame& f) {
        if (frames_ != 0 && f.tick != next_tick_) ++gaps_;
        next_tick_ = f.tick + 1u;
        const T r = f.value[0], y = f.value[1], u = f.value[2];
        hash_.add_sample(r);
        hash_.add_sample(y);
        hash_.add_sample(u);
        const float u_V = voltage_.to_physical(u);
        if (u_V > u_max_abs_V_ || -u_V > u_max_abs_V_) u_max_abs_V_ = u_V < 0.0f ? -u_V : u_V;
        if (f.tick >= metric_start_) {
            const float e = position_.to_physical(r - y);
            const float a = e < 0.0f ? -e : e;
            if (a > e_max_um_) e_max_um_ = a;
            sum_e2_ += static_cast<double>(e) * static_cast<double>(e);
            ++metric_frames_;
        }
        ++frames_;
    }

    uint32_t frames() const { return frames_; }
    uint32_t gaps() const { return gaps_; }
    uint64_t log_hash() const { return hash_.value(); }
    float e_max_um() const { return e_max_um_; }
    float u_max_abs_V() const { return u_max_abs_V_; }
    double e_rms_um() const {
        return metric_frames_ == 0 ? 0.0 : __builtin_sqrt(sum_e2_ / static_cast<double>(metric_frames_));
    }

private:
    SignalScale position_;
    SignalScale voltage_;
    uint32_t metric_start_;
    reference::LogHash hash_{};
    uint32_t frames_ = 0;
    uint32_t next_tick_ = 0;
    uint32_t gaps_ = 0;
    uint32_t metric_frames_ = 0;
    float e_max_um_ = 0.0f;
    float u_max_abs_V_ = 0.0f;
    double sum_e2_ = 0.0;
};

}  // namespace piezoloop::fw
