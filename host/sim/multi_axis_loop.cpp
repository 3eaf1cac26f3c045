#include "sim/multi_axis_loop.hpp"

#include <algorithm>
#include <array>
#include <chrono>
#include <memory>
#include <stdexcept>
#include <string>

#include "piezoloop/approach.hpp"
#include "piezoloop/axes/emulated_coupled_stage.hpp"
#include "piezoloop/axes/multi_axis_pipeline.hpp"
#include "piezoloop/reference_run.hpp"
#include "sim/coupled_stage_build.hpp"
#include "sim/window_metrics.hpp"
#include "status_text.hpp"
#include "sim/f32.hpp"

namespace piezoloop::sim {

namespace {

[[noreturn]] void reject(const std::string& what, const Status& s) {
    throw std::invalid_argument(what + ": " + describe(s));
}

template <int N>
AxisMatrix<N> output_matrix_of(const MultiAxisModel& m) {
    AxisMatrix<N> a = AxisMatrix<N>::identity();
    if (m.output_matrix.empty()) return a;
    for (int i = 0; i < N; ++i)
        for (int j = 0; j < N; ++j) a.m[i][j] = f32(m.output_matrix[static_cast<size_t>(i)][static_cast<size_t>(j)]);
    return a;
}

template <int N>
InputMatrix<N> input_matrix_of(const MultiAxisModel& m) {
    InputMatrix<N> a{};
    for (int i = 0; i < N; ++i) {
        for (int j = 0; j < N && !m.input_matrix.empty(); ++j)
            a.gain.m[i][j] = f32(m.input_matrix[static_cast<size_t>(i)][static_cast<size_t>(j)]);
        if (!m.input_offset_um.empty()) a.offset_um[static_cast<size_t>(i)] = f32(m.input_offset_um[static_cast<size_t>(i)]);
    }
    return a;
}

TrajectoryConfig axis_wave(const MultiAxisModel& m, const MultiAxisRunOptions& o, int i) {
    TrajectoryConfig w = i == o.driven ? o.wave : hold_wave(o.wave, o.hold_um[static_cast<size_t>(i)]);
    w.sample_rate_Hz = m.axes[static_cast<size_t>(i)].model.setup.rate_Hz;
    return w;
}

template <class T, int N>
MultiAxisRunResult run_n(const MultiAxisModel& m, const MultiAxisRunOptions& o) {
    using Pipe = MultiAxisPipeline<T, N, kSimRcCapacity>;
    MultiAxisSetup<N> setup{};
    for (int i = 0; i < N; ++i) {
        setup.axes[static_cast<size_t>(i)] = m.axes[static_cast<size_t>(i)].model.setup;
        setup.channels[static_cast<size_t>(i)] = m.axes[static_cast<size_t>(i)].model.setup.hard;
    }
    auto pipe = std::make_unique<Pipe>(setup);
    if (const Status s = pipe->setup_status(); !s.ok()) reject("setup", s);
    if (const Status s = pipe->set_output_matrix(output_matrix_of<N>(m)); !s.ok()) reject("output_matrix", s);
    if (const Status s = pipe->set_input_matrix(input_matrix_of<N>(m)); !s.ok()) reject("input_matrix", s);
    std::array<SignalScale, N> pos{}, volt{};
    for (int i = 0; i < N; ++i) {
        const size_t a = static_cast<size_t>(i);
        auto& axis = pipe->axis(i);
        if (const Status s = axis.limiter().hard_status(); !s.ok()) reject(m.names[a] + ": setup.hard", s);
        if (const Status s = axis.stage(m.axes[a].model.params); !s.ok()) reject(m.names[a] + ": controller", s);
        if (i != o.driven || o.wave_tick == 0)
            if (const Status s = axis.start_wave(axis_wave(m, o, i)); !s.ok()) reject(m.names[a] + ": trajectory", s);
        pos[a] = m.axes[a].model.setup.position;
        volt[a] = m.axes[a].model.setup.voltage;
    }
    // The coupled stage behind the loop's one tick of delay and the
    // conversions, as the emulated boards run it.
    auto emu = std::make_unique<EmulatedCoupledStage<T, N>>();
    CoupledStageConfig sc = m.stage;
    for (int i = 0; i < sc.axes; ++i) sc.axis[static_cast<size_t>(i)].rate_Hz = setup.axes[0].rate_Hz;
    if (sc.axes != N) throw std::invalid_argument("plant.axes: the stage and the controller differ in axes");
    if (const Status s = emu->configure(sc, pos, volt); !s.ok()) reject("plant", s);
    const CoupledStage& stage = emu->stage();
    pipe->arm_all();

    reference::LogHash hash;
    std::vector<WindowMetrics> window;
    for (int i = 0; i < N; ++i) window.emplace_back(axis_wave(m, o, i).offset_um);
    std::array<float, N> p_min{}, p_max{};
    MultiAxisRunResult res;
    if (o.log_every != 0) {
        res.log.r_um.resize(N);
        res.log.y_um.resize(N);
        res.log.u_V.resize(N);
        res.log.p_um.resize(N);
    }

    std::array<float, N> u_V{};
    const auto t0 = std::chrono::steady_clock::now();
    for (uint64_t k = 0; k < o.ticks; ++k) {
        if (k == o.wave_tick && k != 0)
            if (const Status s = pipe->axis(o.driven).start_wave(axis_wave(m, o, o.driven)); !s.ok())
                reject(m.names[static_cast<size_t>(o.driven)] + ": trajectory", s);
        emu->tick(*pipe);
        const typename Pipe::Samples& u = emu->commands();
        if (o.hash) {
            for (int i = 0; i < N; ++i) {
                const TickSignals<T>& sig = pipe->axis(i).last();
                hash.add_sample(sig.r);
                hash.add_sample(sig.y);
                hash.add_sample(u[static_cast<size_t>(i)]);
            }
        }
        for (int i = 0; i < N; ++i) u_V[static_cast<size_t>(i)] = volt[static_cast<size_t>(i)].to_physical(u[static_cast<size_t>(i)]);
        emu->step();
        const bool in_window = k >= o.window_start;
        const bool logged = o.log_every != 0 && k % o.log_every == 0;
        if (logged) res.log.tick.push_back(k);
        for (int i = 0; i < N; ++i) {
            const size_t a = static_cast<size_t>(i);
            const TickSignals<T>& sig = pipe->axis(i).last();
            const float r_um = pos[a].to_physical(sig.r), y_um = pos[a].to_physical(sig.y);
            const float p_um = stage.position_um(i);
            if (in_window) {
                window[a].add(r_um, y_um);
                if (k == o.window_start) p_min[a] = p_max[a] = p_um;
                p_min[a] = std::min(p_min[a], p_um);
                p_max[a] = std::max(p_max[a], p_um);
            }
            if (logged) {
                res.log.r_um[a].push_back(r_um);
                res.log.y_um[a].push_back(y_um);
                res.log.u_V[a].push_back(u_V[a]);
                res.log.p_um[a].push_back(p_um);
            }
        }
    }
    res.wall_s = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
    res.ticks = o.ticks;
    res.log_hash = hash.value();
    for (int i = 0; i < N; ++i) {
        const size_t a = static_cast<size_t>(i);
        AxisRunResult ar;
        ar.tracking = window[a].tracking();
        ar.position_min_um = p_min[a];
        ar.position_max_um = p_max[a];
        ar.trip = pipe->axis(i).limiter().trip_reason();
        ar.clamped_samples = pipe->axis(i).limiter().clamped_samples();
        ar.channel_clamped_samples = pipe->channel_clamped_samples(i);
        res.axes.push_back(ar);
    }
    return res;
}

template <class T>
MultiAxisRunResult run_sample(const MultiAxisModel& m, const MultiAxisRunOptions& o) {
    switch (m.axes.size()) {
        case 1: return run_n<T, 1>(m, o);
        case 2: return run_n<T, 2>(m, o);
        case 3: return run_n<T, 3>(m, o);
        default: throw std::invalid_argument("plant.axes: 1 to 3 axes");
    }
}

}  // namespace

TrajectoryConfig hold_wave(const TrajectoryConfig& driven, float hold_um) {
    TrajectoryConfig w{};
    w.waveform = Waveform::kSine;
    w.amplitude_um = 0.0f;
    w.offset_um = hold_um;
    w.frequency_Hz = driven.frequency_Hz;
    w.sample_rate_Hz = driven.sample_rate_Hz;
    return w;
}

MultiAxisModel build_multi_axis_case(const Scenario& s, const CaseSpec& c, const BuildOptions& o) {
    MultiAxisModel m;
    m.sample = c.sample;
    m.output_matrix = c.output_matrix;
    m.input_matrix = c.input_matrix;
    m.input_offset_um = c.input_offset_um;
    m.stage = coupled_stage_config(s);
    if (s.axes.empty()) {
        m.names = {"x"};
        m.axes.push_back(build_case(s, c, o));
    } else {
        for (size_t i = 0; i < s.axes.size(); ++i) {
            const Scenario alone = axis_alone(s, i);
            CaseSpec ac = c.axis_cases.empty() ? c : c.axis_cases[i];
            ac.sample = c.sample;
            m.names.push_back(s.axes[i].name);
            BuildOptions ao = o;
            if (i < o.axis_reference_frequency_Hz.size()) ao.reference_frequency_Hz = o.axis_reference_frequency_Hz[i];
            m.axes.push_back(build_case(alone, ac, ao));
        }
    }
    // The axes' stages as their cases built them (a single-axis case's
    // hysteresis override included).
    for (size_t i = 0; i < m.axes.size(); ++i) m.stage.axis[i] = m.axes[i].model.stage;
    return m;
}

MultiAxisRunResult run_multi_axis(const MultiAxisModel& m, const MultiAxisRunOptions& o) {
    const int n = static_cast<int>(m.axes.size());
    if (o.driven < 0 || o.driven >= n) throw std::invalid_argument("axis: must be one of the stage's axes");
    if (o.hold_um.size() != m.axes.size()) throw std::invalid_argument("hold_um: one entry per axis");
    if (o.window_start >= o.ticks && o.ticks != 0) throw std::invalid_argument("run: window_start must be < ticks");
    if (o.wave_tick >= o.ticks && o.ticks != 0) throw std::invalid_argument("run: wave_tick must be < ticks");
    return m.sample == SampleType::kQ31 ? run_sample<Q31>(m, o) : run_sample<float>(m, o);
}

uint64_t multi_axis_approach_ticks(const MultiAxisModel& m, const MultiAxisRunOptions& o, int axis) {
    RunOptions ro;
    ro.wave = axis_wave(m, o, axis);
    return approach_ticks(m.axes[static_cast<size_t>(axis)].model, ro);
}

double cross_motion_pct(const MultiAxisRunResult& r, int driven, int j) {
    const double range = r.axes[static_cast<size_t>(driven)].tracking.range_um;
    const AxisRunResult& a = r.axes[static_cast<size_t>(j)];
    return range > 0.0 ? 100.0 * (a.position_max_um - a.position_min_um) / range : 0.0;
}

}  // namespace piezoloop::sim
