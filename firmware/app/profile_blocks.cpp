// Where the tick's instructions go: the reference pipeline with all blocks
// (reference::all_blocks_params()) run in a plain loop against the
// emulated stage, and beside it a standalone copy of each core block,
// configured exactly as Pipeline::configure_bank configures it and fed the
// same signals as the pipeline's block saw that tick, each timed alone with
// the board's stopwatch. One JSON line per block:
//   {"board","block","<unit>_min","<unit>_mean","<unit>_max"}
// then {"board","block":"sum_of_blocks",...} and the difference to the
// whole tick ("pipeline_overhead": what Pipeline::tick adds around its
// blocks: atomics, the signal vector, dispatch). Also timed: one of the RC's
// two Q filters alone, and the candidate play loops of profile_variants.hpp
// with the number of ticks on which their output differed from the core's
// ("mismatches_vs_core", must be 0 for a drop-in change). Not part of the
// budget check: a measurement aid (docs/boards.md, "Budget").
#include <array>
#include <bit>
#include <cstdint>
#include <new>
#include <span>

#include "app/control_config.hpp"
#include "app/core_sample.hpp"
#include "app/json_line.hpp"
#include "app/profile_variants.hpp"
#include "app/selftest_cases.hpp"
#include "app/tick_stats.hpp"
#include "board_config.hpp"
#include "bsp/bsp.hpp"
#include "piezoloop/emulated_stage.hpp"
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

// The RC's Q filter alone (one of the two the RC runs per tick).
BiquadCascade<T, 1> g_q;

enum Block { kWhole, kAdc, kDac, kTraj, kPi, kSos, kRc, kLim, kRec, kPlant, kQ, kVarA, kVarB, kVarC, kVarD, kBlocks };
constexpr const char* kNames[kBlocks] = {"pipeline_tick", "adc_to_sample",  "sample_to_dac",
                                         "trajectory",    "pi_inverse_15",  "feedback_sos_3",
                                         "rc_n100",       "limiter",        "recorder_push",
                                         "plant_model",   "rc_q_filter_one", "proposal_a",
                                         "proposal_b",    "proposal_c",      "proposal_d"};
// Proposals for the play loop (profile_variants.hpp): names and mismatch
// counts against the core's operator.
#if PIEZOLOOP_FW_SAMPLE_Q31
constexpr const char* kVarNames[4] = {"pi_inverse_15_q31_int32_clamp", "", "", ""};
variants::PiQ31Clamp g_var_a;
#else
constexpr const char* kVarNames[4] = {"pi_inverse_15_minmaxnum", "pi_inverse_15_minmaxnum_unrolled",
                                      "feedback_sos_3_df2t", "feedback_sos_3_delta"};
variants::PiFloatMinMax g_var_a;
variants::PiFloatMinMaxUnrolled<14> g_var_b;  // the reference inverse: p0 + 14 play operators
variants::SosFloatDf2t<3> g_var_c;   // the cost of each float form alone
variants::SosFloatDelta<3> g_var_d;
#endif
uint32_t g_mismatch[4] = {0, 0, 0, 0};
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
#if PIEZOLOOP_FW_SAMPLE_Q31
    if (!g_var_a.configure(inverse, pos, volt)) return false;
#else
    if (!g_var_a.configure(inverse) || !g_var_b.configure(inverse)) return false;
    if (!g_var_c.configure(p.sos.data(), p.sos_count) || !g_var_d.configure(p.sos.data(), p.sos_count)) return false;
#endif
    const SignalScale unit{1.0f};
    if (!g_q.configure(&p.rc.q, 1, unit, unit).ok()) return false;
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
    EmulatedStage<T> stage;
    if (!prepare_case<T>(pipe, stage, c).ok() ||
        !configure(c.params, pipe.setup().position, pipe.setup().voltage)) {
        JsonLine j;
        j.str("board", bsp::kBoardName).str("error", "configure").flush();
        return 1;
    }
    std::array<typename FwPipeline<T>::RecorderType::Frame, 64> frames;

    for (uint32_t k = 0; k < kTicks; ++k) {
        const T y = timed(kAdc, [&] { return stage.reading(); });
        const T u = timed(kWhole, [&] { return pipe.tick(y); });
        timed(kDac, [&] {
            stage.command(u);
            return 0;
        });
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
        const T ff = timed(kPi, [&] { return g_pi.apply(s.r); });
        const T va = timed(kVarA, [&] { return g_var_a.apply(s.r); });
#if PIEZOLOOP_FW_SAMPLE_Q31
        if (!(va == ff)) ++g_mismatch[0];
#endif
#if !PIEZOLOOP_FW_SAMPLE_Q31
        const T vb = timed(kVarB, [&] { return g_var_b.apply(s.r); });
        if (std::bit_cast<uint32_t>(va) != std::bit_cast<uint32_t>(ff)) ++g_mismatch[0];
        if (std::bit_cast<uint32_t>(vb) != std::bit_cast<uint32_t>(ff)) ++g_mismatch[1];
#endif
        timed(kQ, [&] { return g_q.apply(s.e); });
        timed(kRc, [&] { return g_rc.apply(s.e); });
        [[maybe_unused]] const T fb = timed(kSos, [&] { return g_sos.apply(s.e + s.u_rc); });
#if !PIEZOLOOP_FW_SAMPLE_Q31
        const T vc = timed(kVarC, [&] { return g_var_c.apply(s.e + s.u_rc); });
        if (std::bit_cast<uint32_t>(vc) != std::bit_cast<uint32_t>(fb)) ++g_mismatch[2];
        const T vd = timed(kVarD, [&] { return g_var_d.apply(s.e + s.u_rc); });
        if (std::bit_cast<uint32_t>(vd) != std::bit_cast<uint32_t>(fb)) ++g_mismatch[3];
#endif
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
        if (w.count == 0) continue;
        JsonLine j;
        const bool proposal = b >= kVarA;
        j.str("board", bsp::kBoardName).str("sample", kCoreSampleName);
        j.str("block", proposal ? kVarNames[b - kVarA] : kNames[b]);
        if (proposal) j.uint("mismatches_vs_core", g_mismatch[b - kVarA]);
        j.uint({unit, "_min"}, w.min).fixed({unit, "_mean"}, static_cast<double>(w.mean_tenths()) / 10.0, 1);
        j.uint({unit, "_max"}, w.max).flush();
        if (b >= kTraj && b <= kRec) sum_tenths += w.mean_tenths();  // the blocks inside pipeline.tick
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
