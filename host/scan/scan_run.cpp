#include "scan/scan_run.hpp"

#include <array>
#include <memory>
#include <stdexcept>

#include "piezoloop/axes/coupled_stage.hpp"
#include "piezoloop/axes/multi_axis_pipeline.hpp"
#include "piezoloop/scan/scan_feed.hpp"
#include "piezoloop/scan/scan_generator.hpp"
#include "scan/virtual_probe.hpp"
#include "sim/coupled_stage_build.hpp"
#include "status_text.hpp"

namespace piezoloop::scan {
namespace {

[[noreturn]] void reject(const std::string& what, const Status& s) {
    throw std::invalid_argument(what + ": " + describe(s));
}

LimitsConfig limits_of(const sim::Scenario& s) {
    if (s.limits.u_max_V > s.limits.u_min_V) return s.limits;
    return LimitsConfig{s.setup.hard.u_min_V, s.setup.hard.u_max_V, s.setup.hard.slew_max_V_per_s, 0.0f};
}

template <int N>
ScanRunResult run_with(const sim::Scenario& s, const ScanRunOptions& o) {
    using Pipe = MultiAxisPipeline<float, N, 1>;
    MultiAxisSetup<N> setup{};
    for (int i = 0; i < N; ++i) {
        setup.axes[static_cast<std::size_t>(i)] = s.setup;
        setup.channels[static_cast<std::size_t>(i)] = s.setup.hard;
    }
    auto pipe = std::make_unique<Pipe>(setup);
    if (const Status st = pipe->setup_status(); !st.ok()) reject("setup", st);
    const std::vector<double> gains = static_gains_V_per_um(s);
    for (int i = 0; i < N; ++i) {
        PipelineParams p{};
        p.feedforward = FeedforwardKind::kPiCompensator;
        p.pi = PiModel{1.0f, 0.0f, static_cast<float>(gains[static_cast<std::size_t>(i)]), 0, {}, {}};
        p.limits = limits_of(s);
        if (const Status st = pipe->axis(i).stage(p); !st.ok()) reject("axis " + std::to_string(i), st);
    }

    CoupledStage stage;
    const CoupledStageConfig sc = sim::coupled_stage_config(s);
    if (const Status st = stage.configure(sc); !st.ok()) reject("plant", st);
    std::array<float, N> gain{};
    for (int i = 0; i < N; ++i) gain[static_cast<std::size_t>(i)] = sc.axis[static_cast<std::size_t>(i)].sensor.gain;

    ScanConfig cfg = o.scan;
    cfg.sample_rate_Hz = s.setup.rate_Hz;
    ScanFeed<float> feed(s.setup.position, s.setup.position, s.setup.position, s.setup.rate_Hz);
    const VirtualProbe probe(o.sample);

    // The stage at rest: one tick disarmed (command at the safe value) to
    // read where it is, then armed, from its readings.
    ScanRunResult res;
    res.V_per_um = gains;
    for (int i = 0; i < 2; ++i) {
        const auto t = axis_travel_um(s, i);
        res.travel_um.push_back(t.first);
        res.travel_um.push_back(t.second);
    }
    typename Pipe::Samples y{};
    std::array<float, N> readings{};
    {
        const auto u = pipe->tick(y);
        stage.step(u.data(), readings.data());
        for (int i = 0; i < N; ++i) y[static_cast<std::size_t>(i)] = readings[static_cast<std::size_t>(i)] / gain[static_cast<std::size_t>(i)];
    }
    // z, if any, is held where it is.
    float z = 0.0f;
    if constexpr (N > 2) z = y[2];
    cfg.hold_z_um = z;
    if (const Status st = feed.start(cfg, y[0], y[1], z); !st.ok()) reject("scan", st);
    res.approach_ticks = feed.approach_ticks();
    for (int i = 0; i < N; ++i) pipe->axis(i).set_setpoint(y[static_cast<std::size_t>(i)]);
    pipe->arm_all();

    const uint64_t total = uint64_t{feed.approach_ticks()} +
                           uint64_t{feed.generator().frame_period_ticks()} * (cfg.frames == 0 ? 1u : cfg.frames);
    uint64_t k = 0;
    while (!feed.done()) {
        if ((k & 1023u) == 0 && o.stop_requested && o.stop_requested()) break;
        if ((k & 32767u) == 0 && o.progress) o.progress(k, total);
        const bool scanning = !feed.approaching();
        const ScanPoint<float> p = feed.feed(*pipe);
        const auto u = pipe->tick(y);
        stage.step(u.data(), readings.data());
        for (int i = 0; i < N; ++i) y[static_cast<std::size_t>(i)] = readings[static_cast<std::size_t>(i)] / gain[static_cast<std::size_t>(i)];
        ++k;
        if (!scanning) continue;
        ScanTick t;
        t.commanded_x_um = p.x;
        t.commanded_y_um = p.y;
        t.measured_x_um = y[0];
        t.measured_y_um = y[1];
        t.true_x_um = stage.position_um(0);
        t.true_y_um = stage.position_um(1);
        t.height_nm = probe.read_nm(stage);
        t.sync = p.sync;
        res.ticks.push_back(t);
    }
    res.complete = feed.done();
    res.frames_completed = feed.generator().frames_completed();
    if (o.progress) o.progress(k, total);
    return res;
}

}  // namespace

std::vector<double> static_gains_V_per_um(const sim::Scenario& s) {
    std::vector<double> g;
    for (const sim::AxisSpec& a : s.axes) g.push_back(1.0 / (s.nominal_um_per_V * a.plant.amplifier.gain));
    return g;
}

std::pair<double, double> axis_travel_um(const sim::Scenario& s, int axis) {
    const LimitsConfig l = limits_of(s);
    const double g = static_gains_V_per_um(s)[static_cast<std::size_t>(axis)];
    return {l.u_min_V / g, l.u_max_V / g};
}

ScanRunResult run_scan(const sim::Scenario& s, const ScanRunOptions& o) {
    if (s.axes.size() < 2)
        throw std::invalid_argument("scenario: a scan needs a stage of two or three axes (plant.axes), " +
                                    std::to_string(s.axes.size() > 0 ? s.axes.size() : 1) + " given");
    // The scan within each axis's travel, before anything moves.
    ScanConfig cfg = o.scan;
    cfg.sample_rate_Hz = s.setup.rate_Hz;
    ScanGenerator<float> g(s.setup.position, s.setup.position, s.setup.position);
    if (const Status st = g.configure(cfg); !st.ok()) reject("scan", st);
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
    return s.axes.size() == 2 ? run_with<2>(s, o) : run_with<3>(s, o);
}

}  // namespace piezoloop::scan
