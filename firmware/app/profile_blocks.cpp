// Where the tick's instructions go: the reference pipeline with all blocks
// (reference::params(true, true, true)) run in a plain loop against the
// emulated stage, and beside it a standalone copy of each core block,
// configured exactly as Pipeline::configure_bank configures it and fed the
// same signals as the pipeline's block saw that tick, each timed alone with
// the board's stopwatch. One JSON line per block:
//   {"board","block","<unit>_min","<unit>_mean","<unit>_max"}
// then {"board","block":"sum_of_blocks",...} and the difference to the
// whole tick ("pipeline_overhead": what Pipeline::tick adds around its
// blocks: atomics, the signal vector, dispatch). Not part of the budget
// check: a measurement aid (docs/boards.md, "Budget").
#include <array>
#include <cstdint>
#include <new>
#include <span>

#include "app/control_config.hpp"
#include "app/core_sample.hpp"
#include "app/json_line.hpp"
#include "app/selftest_cases.hpp"
#include "app/tick_stats.hpp"
#include "board_config.hpp"
#include "bsp/bsp.hpp"
#include "bsp/emulated_stage.hpp"
#include "piezoloop/pi_inverse.hpp"

namespace {

using namespace piezoloop;
using namespace piezoloop::fw;
using T = CoreSample;

constexpr uint32_t kTicks = 20000;

FwPipeline<T>* g_pipe = nullptr;
alignas(FwPipeline<T>) unsigned char g_pipe_storage[sizeof(FwPipeline<T>)];

// Standalone blocks, as Pipeline::configure_bank makes them.
PiOperator<T> g_pi;
BiquadCascade<T, kMaxControllerSections> g_sos;
RepetitiveController<T, kRcCapacity> g_rc;
Recorder<T, kRecChannels, kRecCapacity> g_rec;
TrajectoryGenerator<T> g_traj{SignalScale{kEmulatedAnalog.position_full_scale_um}};
OutputLimiter<T> g_lim{kEmulatedAnalog.hard, kLoopRate_Hz, SignalScale{kEmulatedAnalog.voltage_full_scale_V}};

enum Block { kWhole, kAdc, kDac, kTraj, kPi, kSos, kRc, kLim, kRec, kPlant, kBlocks };
constexpr const char* kNames[kBlocks] = {"pipeline_tick", "adc_to_sample",  "sample_to_dac",
                                         "trajectory",    "pi_inverse_15",  "feedback_sos_3",
                                         "rc_n100",       "limiter",        "recorder_push",
                                         "plant_model"};
WorkStats g_stats[kBlocks];

// Times f() (the result is kept alive so the call is not optimised away).
template <class F>
__attribute__((always_inline)) inline auto timed(Block b, F&& f) {
    const uint32_t s = bsp::stopwatch_start();
    auto r = f();
    asm volatile("" ::"r"(&r) : "memory");
    g_stats[b].add(bsp::stopwatch_elapsed(s));
    return r;
}

bool configure(const PipelineParams& p, const SignalScale pos, const SignalScale volt) {
    PiModel inverse{};
    if (!invert_pi(p.pi, inverse).ok() || !g_pi.configure(inverse, pos, volt).ok()) return false;
    if (!g_sos.configure(p.sos.data(), p.sos_count, pos, volt).ok()) return false;
    if (!g_rc.configure(p.rc).ok()) return false;
    if (!g_lim.configure(p.limits).ok()) return false;
    if (!g_rec.configure(log_recorder_config<T>()).ok() || !g_rec.arm()) return false;
    return g_traj.configure(reference_wave()).ok();
}

}  // namespace

int app_main() {
    const SelfTestCase& c = kSelfTestCases[0];  // reference_all_blocks
    g_pipe = new (g_pipe_storage) FwPipeline<T>(pipeline_setup(kEmulatedAnalog));
    FwPipeline<T>& pipe = *g_pipe;
    EmulatedStage stage{kEmulatedAnalog.position_full_scale_um, kEmulatedAnalog.voltage_full_scale_V};
    const Converter16& adc = stage.adc();
    const Converter16& dac = stage.dac();
    if (!prepare_case<T>(pipe, stage, c).ok() ||
        !configure(c.params, pipe.setup().position, pipe.setup().voltage)) {
        JsonLine j;
        j.str("board", bsp::kBoardName).str("error", "configure").flush();
        return 1;
    }
    std::array<typename FwPipeline<T>::RecorderType::Frame, 64> frames;

    for (uint32_t k = 0; k < kTicks; ++k) {
        const int32_t code = stage.adc_code();
        const T y = timed(kAdc, [&] { return adc.sample_from_code<T>(code); });
        const T u = timed(kWhole, [&] { return pipe.tick(y); });
        const int32_t out = timed(kDac, [&] { return dac.code_from_sample(u); });
        stage.dac_write(out);
        timed(kPlant, [&] {
            stage.step();
            return 0;
        });
        while (pipe.recorder().read(std::span(frames)) != 0) {
        }
        if (k == 0) continue;  // the first tick swaps the parameters in and resets
        // The blocks alone, on the signals the pipeline's blocks saw.
        const TickSignals<T>& s = pipe.last();
        timed(kTraj, [&] { return g_traj.step(); });
        timed(kPi, [&] { return g_pi.apply(s.r); });
        timed(kRc, [&] { return g_rc.apply(s.e); });
        timed(kSos, [&] { return g_sos.apply(s.e + s.u_rc); });
        timed(kLim, [&] { return g_lim.apply(s.u_ff + s.u_fb); });
        timed(kRec, [&] {
            g_rec.push(k, {s.r, s.y, s.e, s.u, s.u_ff, s.u_fb, s.u_rc});
            return 0;
        });
        while (g_rec.read(std::span(frames)) != 0) {
        }
    }

    const char* unit = bsp::config::kWorkUnit;
    uint64_t sum_tenths = 0;
    for (int b = 0; b < kBlocks; ++b) {
        const WorkStats& w = g_stats[b];
        JsonLine j;
        j.str("board", bsp::kBoardName).str("sample", kCoreSampleName).str("block", kNames[b]);
        j.uint({unit, "_min"}, w.min).fixed({unit, "_mean"}, static_cast<double>(w.mean_tenths()) / 10.0, 1);
        j.uint({unit, "_max"}, w.max).flush();
        if (b >= kTraj && b <= kRec) sum_tenths += w.mean_tenths();
    }
    const uint64_t whole = g_stats[kWhole].mean_tenths();
    JsonLine j;
    j.str("board", bsp::kBoardName).str("block", "sum_of_blocks_in_tick");
    j.fixed({unit, "_mean"}, static_cast<double>(sum_tenths) / 10.0, 1);
    j.fixed({"pipeline_overhead_", unit, "_mean"},
            (static_cast<double>(whole) - static_cast<double>(sum_tenths)) / 10.0, 1);
    j.uint({unit, "_resolution_per_block"}, bsp::config::kStopwatchResolution).flush();
    return 0;
}
