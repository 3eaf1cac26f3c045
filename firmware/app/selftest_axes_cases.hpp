// The self-test's multi-axis case: its setup, and what is computed from the
// recorded logs. Shared by the firmware (app/selftest_axes.cpp, which runs
// it in the tick interrupt) and the host (tests/firmware/host_selftest.cpp,
// which runs the same steps in a plain loop), so that the log hashes can
// only differ if the core computes differently.
//
// N axes (X, Y, Z), each the reference pipeline of reference_all_blocks
// (reference::all_blocks_params() discretised at the case's loop rate: the
// same continuous design), each with its own reference:
//   X  triangle, 15 µm, 10 Hz   (the single-axis cases' wave)
//   Y  triangle, 10 µm,  4 Hz
//   Z  sine,      5 µm, 20 Hz
// through a static decoupling output matrix (the top-left N x N block of
// kDecoupling3, row i = channel i) to a CoupledStage of N reference stages
// (reference::plant(), ideal converters) whose axes move each other by a
// few % (static paths, µm of position per µm of displacement):
//   X -> Y 2.5 %, Y -> X 3 %, X -> Z 6 %, Y -> Z 6.7 %
// which the matrix cancels to first order (the paths act on displacements,
// the matrix on voltages; the stages' slope is near 4.4 µm/V on each axis).
// qemu-m7 (float) runs it at 100 kHz with 1, 2 and 3 axes, qemu-m3 (Q31)
// at 50 kHz with 1 and 2 (kSelfTestAxes in bsp/<board>/board_config.hpp);
// 0.2 s each, tracking figures from 20 ms on.
//
// Log: each axis's recorder {r, y, u, e} (u: the axis's command before the
// output matrix); log_hash_<i> is axis i's LogHash over r, y, u of every
// frame as for the single-axis cases; log_hash folds the N axis hashes
// (low word, high word, axis order) into one LogHash. The channel commands
// reach every y through the coupled stage, so every axis's hash depends on
// the output matrix's arithmetic.
#pragma once

#include <array>
#include <cstdint>
#include <type_traits>

#include "app/control_config.hpp"
#include "app/json_line.hpp"
#include "app/selftest_cases.hpp"
#include "piezoloop/axes/coupled_stage.hpp"
#include "piezoloop/axes/emulated_coupled_stage.hpp"
#include "piezoloop/axes/multi_axis_pipeline.hpp"
#include "piezoloop/reference_stage.hpp"

namespace piezoloop::fw {

template <class T, int N>
using FwAxesPipeline = MultiAxisPipeline<T, N, kRcCapacity, kRecChannels, kRecCapacity, kExcCapacity, kBoardRecChannels>;

// The loop rate: float 100 kHz, Q31 50 kHz (the M3's two axes).
template <class T>
inline constexpr uint32_t kAxesRateInt_Hz = std::is_same_v<T, float> ? 100000u : 50000u;
template <class T>
inline constexpr float kAxesRate_Hz = static_cast<float>(kAxesRateInt_Hz<T>);
// Runs with 1 .. kAxesCount axes: float 3 (qemu-m7), Q31 2 (qemu-m3).
template <class T>
inline constexpr int kAxesCount = std::is_same_v<T, float> ? 3 : 2;
template <class T>
inline constexpr uint32_t kAxesTicks = kAxesRateInt_Hz<T> / 5u;         // 0.2 s
template <class T>
inline constexpr uint32_t kAxesMetricStart = kAxesRateInt_Hz<T> / 50u;  // 20 ms

inline constexpr const char* kAxesCaseNames[kMaxAxes] = {"reference_axes_1", "reference_axes_2",
                                                         "reference_axes_3"};

inline constexpr float kDecoupling3[kMaxAxes][kMaxAxes] = {
    {1.0f, -0.03f, 0.0f},
    {-0.025f, 1.0f, 0.0f},
    {-0.06f, -0.067f, 1.0f},
};

struct AxesCoupling {
    int from;
    int to;
    double gain;  // µm / µm
};
inline constexpr AxesCoupling kAxesCoupling[] = {{0, 1, 0.025}, {1, 0, 0.03}, {0, 2, 0.06}, {1, 2, 0.067}};

template <int N>
constexpr AxisMatrix<N> axes_output_matrix() {
    AxisMatrix<N> m{};
    for (int i = 0; i < N; ++i)
        for (int j = 0; j < N; ++j) m.m[i][j] = kDecoupling3[i][j];
    return m;
}

// Axis i's reference at rate_Hz.
constexpr TrajectoryConfig axes_wave(int axis, float rate_Hz) {
    TrajectoryConfig w{};
    w.sample_rate_Hz = rate_Hz;
    if (axis == 0) {
        w.waveform = Waveform::kTriangle;
        w.amplitude_um = 15.0f;
        w.frequency_Hz = 10.0f;
    } else if (axis == 1) {
        w.waveform = Waveform::kTriangle;
        w.amplitude_um = 10.0f;
        w.frequency_Hz = 4.0f;
    } else {
        w.waveform = Waveform::kSine;
        w.amplitude_um = 5.0f;
        w.frequency_Hz = 20.0f;
    }
    return w;
}

// Every axis the emulated boards' analog side (the reference stage's full
// scales and hard limits), every channel the same hard limits.
template <int N>
constexpr MultiAxisSetup<N> axes_setup(float rate_Hz) {
    MultiAxisSetup<N> s{};
    for (int i = 0; i < N; ++i) {
        s.axes[static_cast<std::size_t>(i)] = pipeline_setup(kEmulatedAnalog, rate_Hz);
        s.channels[static_cast<std::size_t>(i)] = kEmulatedAnalog.hard;
    }
    return s;
}

// Written into `c` (a few KiB: the board keeps it in static storage, off
// the main stack that CoupledStage::configure already fills).
constexpr void axes_stage(int n, float rate_Hz, CoupledStageConfig& c) {
    c = CoupledStageConfig{};
    c.axes = n;
    for (int i = 0; i < n; ++i) c.axis[static_cast<std::size_t>(i)] = ideal_stage(reference::plant(rate_Hz), rate_Hz);
    for (const AxesCoupling& k : kAxesCoupling) {
        if (k.from >= n || k.to >= n) continue;
        CouplingPath& p = c.coupling[static_cast<std::size_t>(c.paths++)];
        p.from = k.from;
        p.to = k.to;
        p.sections = 1;
        p.filter[0] = SosSection{k.gain, 0.0, 0.0, 0.0, 0.0};
    }
}

// With the tick stopped and the pipeline fresh, in the order of
// prepare_case per axis: parameters staged, recorder armed, the output
// matrix requested (taken over at the first tick, before any axis arms),
// the stage at rest, every axis armed, every wave started. stage_config:
// storage for axes_stage().
template <class T, int N, class PipelineT>
Status prepare_axes_case(PipelineT& pipe, EmulatedCoupledStage<T, N>& stage, CoupledStageConfig& stage_config) {
    constexpr float rate = kAxesRate_Hz<T>;
    if (const Status s = pipe.setup_status(); !s.ok()) return s;
    for (int i = 0; i < N; ++i) {
        auto& a = pipe.axis(i);
        if (const Status s = a.stage(reference::all_blocks_params(rate)); !s.ok()) return s;
        if (const Status s = a.recorder().configure(log_recorder_config<T>()); !s.ok()) return s;
        if (!a.recorder().arm()) return error("recorder", "arm refused");
    }
    if (const Status s = pipe.set_output_matrix(axes_output_matrix<N>()); !s.ok()) return s;
    std::array<SignalScale, N> position{}, voltage{};
    for (int i = 0; i < N; ++i) {
        position[static_cast<std::size_t>(i)] = pipe.axis(i).setup().position;
        voltage[static_cast<std::size_t>(i)] = pipe.axis(i).setup().voltage;
    }
    axes_stage(N, rate, stage_config);
    if (const Status s = stage.configure(stage_config, position, voltage); !s.ok()) return s;
    pipe.arm_all();
    for (int i = 0; i < N; ++i)
        if (const Status s = pipe.axis(i).start_wave(axes_wave(i, rate)); !s.ok()) return s;
    return ok_status();
}

// One LogAccumulator per axis.
template <class T, int N>
struct AxesLog {
    std::array<LogAccumulator<T>, N> axis;

    template <class PipelineT>
    static AxesLog make(const PipelineT& pipe) {
        return make(pipe, std::make_index_sequence<N>{});
    }
    uint32_t frames() const {
        uint32_t f = axis[0].frames();
        for (const auto& a : axis) f = a.frames() < f ? a.frames() : f;
        return f;
    }
    uint32_t gaps() const {
        uint32_t g = 0;
        for (const auto& a : axis) g += a.gaps();
        return g;
    }
    uint64_t log_hash() const {
        reference::LogHash h{};
        for (const auto& a : axis) {
            h.add(static_cast<uint32_t>(a.log_hash()));
            h.add(static_cast<uint32_t>(a.log_hash() >> 32));
        }
        return h.value();
    }

private:
    template <class PipelineT, std::size_t... I>
    static AxesLog make(const PipelineT& pipe, std::index_sequence<I...>) {
        return AxesLog{{LogAccumulator<T>(pipe.axis(static_cast<int>(I)).setup().position,
                                          pipe.axis(static_cast<int>(I)).setup().voltage, kAxesMetricStart<T>)...}};
    }
};

// The log fields the board and the host replay both print:
// "axes","frames","gaps","e_max_um","e_rms_um","u_max_abs_V" (the worst
// axis), "log_hash", then per axis "e_max_um_<i>","e_rms_um_<i>","log_hash_<i>".
template <class T, int N>
void add_axes_log_fields(JsonLine& j, const AxesLog<T, N>& log) {
    constexpr const char* kSuffix[kMaxAxes] = {"_0", "_1", "_2"};
    float e_max = 0.0f, u_max = 0.0f;
    double e_rms = 0.0;
    for (const auto& a : log.axis) {
        if (a.e_max_um() > e_max) e_max = a.e_max_um();
        if (a.u_max_abs_V() > u_max) u_max = a.u_max_abs_V();
        if (a.e_rms_um() > e_rms) e_rms = a.e_rms_um();
    }
    j.uint("frames", log.frames()).uint("gaps", log.gaps()).boolean("tracking_valid", true);
    j.fixed("e_max_um", static_cast<double>(e_max), 4).fixed("e_rms_um", e_rms, 4);
    j.fixed("u_max_abs_V", static_cast<double>(u_max), 4).hex64("log_hash", log.log_hash());
    for (int i = 0; i < N; ++i) {
        const auto& a = log.axis[static_cast<std::size_t>(i)];
        j.fixed({"e_max_um", kSuffix[i]}, static_cast<double>(a.e_max_um()), 4);
        j.fixed({"e_rms_um", kSuffix[i]}, a.e_rms_um(), 4);
        j.hex64({"log_hash", kSuffix[i]}, a.log_hash());
    }
}

}  // namespace piezoloop::fw
