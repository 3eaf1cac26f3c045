#include "scan/scan_run.hpp"

#include <array>
#include <memory>
#include <stdexcept>

#include "piezoloop/axes/coupled_stage.hpp"
#include "piezoloop/axes/multi_axis_pipeline.hpp"
#include "piezoloop/scan/scan_feed.hpp"
#include "piezoloop/scan/scan_generator.hpp"
#include "scan/virtual_probe.hpp"
#include "sim/multi_axis_loop.hpp"
#include "status_text.hpp"

namespace piezoloop::scan {
namespace {

[[noreturn]] void reject(const std::string& what, const Status& s) {
    throw std::invalid_argument(what + ": " + describe(s));
}

template <int N>
AxisMatrix<N> output_matrix_of(const sim::MultiAxisModel& m) {
    AxisMatrix<N> a = AxisMatrix<N>::identity();
    if (m.output_matrix.empty()) return a;
    for (int i = 0; i < N; ++i)
        for (int j = 0; j < N; ++j)
            a.m[i][j] = static_cast<float>(m.output_matrix[static_cast<std::size_t>(i)][static_cast<std::size_t>(j)]);
    return a;
}

template <int N>
InputMatrix<N> input_matrix_of(const sim::MultiAxisModel& m) {
    InputMatrix<N> a{};
    for (int i = 0; i < N; ++i) {
        for (int j = 0; j < N && !m.input_matrix.empty(); ++j)
            a.gain.m[i][j] = static_cast<float>(m.input_matrix[static_cast<std::size_t>(i)][static_cast<std::size_t>(j)]);
        if (!m.input_offset_um.empty())
            a.offset_um[static_cast<std::size_t>(i)] = static_cast<float>(m.input_offset_um[static_cast<std::size_t>(i)]);
    }
    return a;
}

template <class T, int N>
ScanRunResult run_with(const sim::MultiAxisModel& m, const ScanRunOptions& o) {
    using Pipe = MultiAxisPipeline<T, N, sim::kSimRcCapacity>;
    MultiAxisSetup<N> setup{};
    std::array<SignalScale, N> pos{}, volt{};
    std::array<float, N> gain{};
    for (int i = 0; i < N; ++i) {
        const std::size_t a = static_cast<std::size_t>(i);
        setup.axes[a] = m.axes[a].model.setup;
        setup.channels[a] = m.axes[a].model.setup.hard;
        pos[a] = setup.axes[a].position;
        volt[a] = setup.axes[a].voltage;
        gain[a] = m.stage.axis[a].sensor.gain;
        if (gain[a] == 0.0f) throw std::invalid_argument(m.names[a] + ": plant.sensor.gain: must be non-zero");
    }
    auto pipe = std::make_unique<Pipe>(setup);
    if (const Status st = pipe->setup_status(); !st.ok()) reject("setup", st);
    if (const Status st = pipe->set_output_matrix(output_matrix_of<N>(m)); !st.ok()) reject("output_matrix", st);
    if (const Status st = pipe->set_input_matrix(input_matrix_of<N>(m)); !st.ok()) reject("input_matrix", st);
    for (int i = 0; i < N; ++i)
        if (const Status st = pipe->axis(i).stage(m.axes[static_cast<std::size_t>(i)].model.params); !st.ok())
            reject(m.names[static_cast<std::size_t>(i)] + ": controller", st);

    CoupledStage stage;
    CoupledStageConfig sc = m.stage;
    for (int i = 0; i < sc.axes; ++i) sc.axis[static_cast<std::size_t>(i)].rate_Hz = setup.axes[0].rate_Hz;
    if (const Status st = stage.configure(sc); !st.ok()) reject("plant", st);
    if (stage.axes() != N) throw std::invalid_argument("plant.axes: the stage and the controller differ in axes");

    const float rate_Hz = setup.axes[0].rate_Hz;
    ScanConfig cfg = o.scan;
    cfg.sample_rate_Hz = rate_Hz;
    ScanFeed<T> feed(pos[0], pos[1], pos[N > 2 ? N - 1 : 0], rate_Hz);
    const VirtualProbe probe(o.sample);

    typename Pipe::Samples y{};
    std::array<float, N> u_V{}, reading{};
    auto tick = [&] {
        const typename Pipe::Samples u = pipe->tick(y);
        for (int i = 0; i < N; ++i)
            u_V[static_cast<std::size_t>(i)] = volt[static_cast<std::size_t>(i)].to_physical(u[static_cast<std::size_t>(i)]);
        stage.step(u_V.data(), reading.data());
        for (int i = 0; i < N; ++i) {
            const std::size_t a = static_cast<std::size_t>(i);
            const float y_um = gain[a] == 1.0f ? reading[a] : reading[a] / gain[a];
            y[a] = pos[a].template to_sample<T>(y_um);
        }
    };
    // At rest. The simulator's own start: one tick holding 0 to read where
    // the stage is, then the scan from there (z held where it is). The
    // board's (StartScan with the loop's arm and the stage's restart): the
    // scan from the restarted stage's zero readings, z held at 0, armed at
    // the approach's first tick.
    for (int i = 0; i < N; ++i) y[static_cast<std::size_t>(i)] = pos[static_cast<std::size_t>(i)].template to_sample<T>(0.0f);
    for (int i = 0; i < N; ++i) pipe->axis(i).set_setpoint(y[static_cast<std::size_t>(i)]);
    pipe->arm_all();
    if (!o.board_start) tick();
    T z{};
    if constexpr (N > 2) {
        z = y[2];
        cfg.hold_z_um = pos[2].to_physical(z);
    }
    if (const Status st = feed.start(cfg, y[0], y[1], z); !st.ok()) reject("scan", st);

    ScanRunResult res;
    res.q31 = !std::is_same_v<T, float>;
    res.approach_ticks = feed.approach_ticks();
    const uint64_t total = uint64_t{feed.approach_ticks()} +
                           uint64_t{feed.generator().frame_period_ticks()} * (cfg.frames == 0 ? 1u : cfg.frames);
    uint64_t k = 0;
    while (!feed.done()) {
        if ((k & 1023u) == 0 && o.stop_requested && o.stop_requested()) break;
        if ((k & 32767u) == 0 && o.progress) o.progress(k, total);
        const bool scanning = !feed.approaching();
        const ScanPoint<T> p = feed.feed(*pipe);
        // A tick's record pairs its reference with the reading its
        // controller compares it with (the core's e = r - y, y after the
        // input matrix, as a board records it): the stage as the previous
        // step left it, where the probe also is.
        ScanTick t;
        if (scanning) {
            t.commanded_x_um = pos[0].to_physical(p.x);
            t.commanded_y_um = pos[1].to_physical(p.y);
            t.true_x_um = stage.position_um(0);
            t.true_y_um = stage.position_um(1);
            t.height_nm = probe.read_nm(stage);
            t.sync = p.sync;
        }
        tick();
        ++k;
        if (scanning) {
            t.measured_x_um = pos[0].to_physical(pipe->axis(0).last().y);
            t.measured_y_um = pos[1].to_physical(pipe->axis(1).last().y);
            res.ticks.push_back(t);
        }
    }
    res.complete = feed.done();
    res.frames_completed = feed.generator().frames_completed();
    if (o.progress) o.progress(k, total);
    return res;
}

}  // namespace

uint32_t scan_rc_period_ticks(const ScanConfig& c, int axis) {
    ScanGenerator<float> g;
    if (const Status st = g.configure(c); !st.ok()) reject("scan", st);
    if (c.pattern == ScanPattern::kLissajous) return g.lissajous_axis_period_ticks(axis);
    const bool cav_spiral = c.pattern == ScanPattern::kSpiral && g.line_period_ticks() > 0;
    return cav_spiral ? g.line_period_ticks() : g.repetitive_period_ticks();
}

std::pair<double, double> axis_travel_um(const sim::Scenario& s, int axis) {
    const double um_per_V = s.nominal_um_per_V * s.axes[static_cast<std::size_t>(axis)].plant.amplifier.gain;
    return {s.setup.hard.u_min_V * um_per_V, s.setup.hard.u_max_V * um_per_V};
}

ScanRunResult run_scan(const sim::Scenario& s, const ScanRunOptions& o) {
    if (s.axes.size() < 2)
        throw std::invalid_argument("scenario: a scan needs a stage of two or three axes (plant.axes)");
    // The controllers' realisation check (a report's note, seconds for slow
    // poles) is not needed to run them.
    ScanConfig cfg = o.scan;
    cfg.sample_rate_Hz = static_cast<float>(s.rate_Hz);
    ScanGenerator<float> g;
    if (const Status st = g.configure(cfg); !st.ok()) reject("scan", st);
    // A repetitive controller's period "auto" is the scan's fast motion on
    // its axis (z holds: x's).
    sim::BuildOptions build;
    build.check_realisation = false;
    for (size_t i = 0; i < s.axes.size(); ++i)
        build.axis_reference_frequency_Hz.push_back(
            s.rate_Hz / static_cast<double>(scan_rc_period_ticks(cfg, i == 1 ? 1 : 0)));
    const sim::MultiAxisModel m = sim::build_multi_axis_case(s, s.find_case(o.case_name), build);
    // The scan within each axis's travel, before anything moves.
    const double reach = g.reach_um();
    const double centre[2] = {cfg.centre_x_um, cfg.centre_y_um};
    const char* names[2] = {"scan.x", "scan.y"};
    for (int i = 0; i < 2; ++i) {
        const auto [lo, hi] = axis_travel_um(s, i);
        if (centre[i] - reach < lo || centre[i] + reach > hi)
            throw std::invalid_argument(std::string(names[i]) + ": the scan reaches [" + std::to_string(centre[i] - reach) +
                                        ", " + std::to_string(centre[i] + reach) + "] um, beyond the axis's travel [" +
                                        std::to_string(lo) + ", " + std::to_string(hi) + "] um");
    }
    const bool q31 = m.sample == sim::SampleType::kQ31;
    if (m.axes.size() == 2) return q31 ? run_with<Q31, 2>(m, o) : run_with<float, 2>(m, o);
    return q31 ? run_with<Q31, 3>(m, o) : run_with<float, 3>(m, o);
}

}  // namespace piezoloop::scan
