#include "measure/mimo_frf_sim.hpp"

#include <array>
#include <chrono>
#include <cmath>
#include <memory>
#include <stdexcept>
#include <string>

#include "piezoloop/axes/channel_output.hpp"
#include "piezoloop/axes/coupled_stage.hpp"
#include "piezoloop/reference_run.hpp"
#include "sim/coupled_stage_build.hpp"
#include "status_text.hpp"
#include "options/option_checks.hpp"

namespace piezoloop::measure {

namespace {

using options::refuse;

template <int N>
MimoFrfSimRun run_with(const sim::Scenario& s, const MimoFrfPlan& plan, const std::optional<Eigen::MatrixXd>& d,
                       const std::function<void(double)>& progress) {
    const CoupledStageConfig sc = sim::coupled_stage_config(s);
    auto stage = std::make_unique<CoupledStage>();
    if (const Status st = stage->configure(sc); !st.ok()) refuse("plant", describe(st));

    // Every channel has the scenario's hard limits; the axes' limiters
    // (none here: open loop) are given the same, so the identity skips the
    // channel stage exactly as on a board.
    std::array<HardLimits, N> hard{};
    std::array<SignalScale, N> voltage{};
    hard.fill(s.setup.hard);
    voltage.fill(s.setup.voltage);
    ChannelOutput<float, N> channels(hard, static_cast<float>(s.rate_Hz), voltage, hard);
    if (const Status st = channels.hard_status(); !st.ok()) refuse("loop.hard_limits", describe(st));
    if (d) {
        if (d->rows() != N || d->cols() != N)
            refuse("--output-matrix", "must be " + std::to_string(N) + " x " + std::to_string(N) + " (the axes)");
        AxisMatrix<N> m{};
        for (int i = 0; i < N; ++i)
            for (int j = 0; j < N; ++j) m.m[i][j] = static_cast<float>((*d)(i, j));
        AxisTransform<float, N> t;
        if (const Status st = channels.prepare(m, t); !st.ok()) refuse("--output-matrix", describe(st));
        channels.set_matrix(t);
    }

    std::array<float, N> gain{};
    for (int i = 0; i < N; ++i) gain[i] = sc.axis[static_cast<std::size_t>(i)].sensor.gain;

    MimoFrfSimRun run;
    run.plan = plan;
    const int n = plan.inputs;
    const uint64_t samples = plan.block_samples;
    std::vector<std::vector<std::vector<double>>> u(static_cast<std::size_t>(n)), y(static_cast<std::size_t>(n));
    reference::LogHash hash;
    const auto t0 = std::chrono::steady_clock::now();
    for (int b = 0; b < n; ++b) {
        // The blocks follow each other on the running stage, as on a board:
        // the discarded periods take up the change of phases.
        const std::vector<std::vector<double>> block = mimo_block(plan, b);
        auto& ub = u[static_cast<std::size_t>(b)];
        auto& yb = y[static_cast<std::size_t>(b)];
        ub.assign(N, std::vector<double>(samples));
        yb.assign(N, std::vector<double>(samples));
        std::array<float, N> axis_cmd{};
        std::array<float, N> reading{};
        for (uint64_t k = 0; k < samples; ++k) {
            for (int j = 0; j < N; ++j) axis_cmd[j] = static_cast<float>(block[static_cast<std::size_t>(j)][k]);
            const std::array<float, N>& c = channels.apply(axis_cmd);
            stage->step(c.data(), reading.data());
            for (int i = 0; i < N; ++i) {
                ub[static_cast<std::size_t>(i)][k] = axis_cmd[i];
                const float y_um = gain[i] == 1.0f ? reading[i] : reading[i] / gain[i];
                yb[static_cast<std::size_t>(i)][k] = y_um;
                hash.add_sample(c[i]);
                hash.add_sample(reading[i]);
            }
        }
        if (progress) progress(static_cast<double>(b + 1) / n);
    }
    run.wall_s = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
    run.log_hash = hash.value();
    for (int i = 0; i < N; ++i) {
        run.clamped_samples.push_back(channels.clamped_samples(i));
        run.slew_limited_samples.push_back(channels.slew_limited_samples(i));
    }
    run.estimate = estimate_mimo_frf(plan, u, y);
    return run;
}

}  // namespace

MimoFrfRequest mimo_request(const sim::Scenario& s, double from_Hz, double to_Hz, double amplitude_V,
                            const std::vector<double>& bias_V, int periods, int transient_periods) {
    if (!s.multi_axis()) refuse("--mimo", "the scenario has one axis: measure it without --mimo");
    const int n = static_cast<int>(s.axes.size());
    MimoFrfRequest r;
    r.inputs = n;
    r.rate_Hz = s.rate_Hz;
    r.from_Hz = from_Hz;
    r.to_Hz = to_Hz;
    r.amplitude_V = amplitude_V;
    if (bias_V.size() == 1) r.bias_V.assign(static_cast<std::size_t>(n), bias_V[0]);
    else if (bias_V.size() == static_cast<std::size_t>(n) || bias_V.empty()) r.bias_V = bias_V;
    else refuse("--bias-v", "one value for every axis, or one per axis (" + std::to_string(n) + ")");
    r.periods = periods;
    r.transient_periods = transient_periods;
    // The whole excursion inside the hard limits: a measurement that clips is
    // not what was asked for (the channel stage would clamp it anyway).
    const HardLimits& h = s.setup.hard;
    for (int i = 0; i < n; ++i) {
        const double b = r.bias_V.empty() ? 0.0 : r.bias_V[static_cast<std::size_t>(i)];
        if (!(b - amplitude_V >= h.u_min_V && b + amplitude_V <= h.u_max_V))
            refuse("--amplitude-v", "bias +- amplitude must lie within the hard limits [" + std::to_string(h.u_min_V) +
                                        ", " + std::to_string(h.u_max_V) + "] V on every axis");
    }
    return r;
}

MimoFrfSimRun run_mimo_frf_sim(const sim::Scenario& s, const MimoFrfRequest& r,
                               const std::optional<Eigen::MatrixXd>& output_matrix,
                               const std::function<void(double)>& progress) {
    const MimoFrfPlan plan = plan_mimo_frf(r);
    switch (plan.inputs) {
        case 2: return run_with<2>(s, plan, output_matrix, progress);
        case 3: return run_with<3>(s, plan, output_matrix, progress);
        default: refuse("--mimo", "a stage of 2 or 3 axes");
    }
}

}  // namespace piezoloop::measure
