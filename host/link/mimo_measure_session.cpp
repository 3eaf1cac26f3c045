#include "link/mimo_measure_session.hpp"

#include <chrono>
#include <optional>
#include <stdexcept>
#include <string>

#include "link/recorded_signals.hpp"
#include "measure/frf_plan.hpp"
#include "measure/mimo_frf_file.hpp"

namespace piezoloop::hostlink {

namespace {

// Every axis's controller groups set to none and put back afterwards (the
// board left disarmed), the recorder group too, whatever happens; the
// excitations stopped on the way out.
template <class F>
void open_loop_axes(Client& c, int n, F&& measure) {
    const link::RecorderParams recorder = c.get<link::RecorderParams>();
    std::vector<ControllerGroups> saved;
    for (int a = 0; a < n; ++a) saved.push_back(read_controller(c, static_cast<uint8_t>(a)));
    const auto put_back = [&] {
        for (int a = 0; a < n; ++a) c.stop_excitation(static_cast<uint8_t>(a));
        c.disarm();
        for (int a = 0; a < n; ++a) write_controller(c, saved[static_cast<std::size_t>(a)], static_cast<uint8_t>(a));
        restore_recorder(c, recorder);
    };
    try {
        c.disarm();
        for (int a = 0; a < n; ++a) write_controller(c, ControllerGroups{}, static_cast<uint8_t>(a));
        measure();
        put_back();
    } catch (...) {
        try {
            c.recorder_stop();
            put_back();
        } catch (const std::exception&) {
        }
        throw;
    }
}

}  // namespace

measure::MimoFrfRequest board_mimo_request(Client& c, double from_Hz, double to_Hz, double amplitude_V, double bias_V,
                                           int periods, int transient_periods) {
    const int n = c.axis_count();
    if (n < 2) throw std::invalid_argument("--mimo: this board has one axis (measure it without --mimo)");
    measure::MimoFrfRequest r;
    r.inputs = n;
    r.rate_Hz = c.info().loop_rate_Hz;
    r.from_Hz = from_Hz;
    r.to_Hz = to_Hz;
    r.amplitude_V = amplitude_V;
    r.bias_V.assign(static_cast<std::size_t>(n), bias_V);
    r.periods = periods;
    r.transient_periods = transient_periods;
    return r;
}

DeviceMimoFrfRun run_mimo_frf_device(Client& c, const measure::MimoFrfRequest& r, const MeasureOptions& o) {
    const link::HelloReply& h = c.info();
    const int n = h.axis_count;
    if (n < 2) throw std::invalid_argument("--mimo: this board has one axis (measure it without --mimo)");
    if (r.inputs != n) throw std::invalid_argument("--mimo: the board has " + std::to_string(n) + " axes");
    if (h.recorder_channels < static_cast<unsigned>(n + 1))
        throw std::invalid_argument("--mimo: this board records " + std::to_string(h.recorder_channels) +
                                    " channels; a block records u and every axis's y (" + std::to_string(n + 1) + ")");
    if (o.restart_stage) throw std::invalid_argument("--restart-stage: not with --mimo (the held axes' biases stay)");
    DeviceMimoFrfRun out;
    out.plan = measure::plan_mimo_frf(r);
    // Each axis's multisine against its own limits, as a single-axis
    // measurement of it would be checked.
    std::vector<ExcitationConfig> multisine, hold;
    for (int a = 0; a < n; ++a) {
        measure::FrfRequest fr;
        fr.from_Hz = r.from_Hz;
        fr.to_Hz = r.to_Hz;
        fr.amplitude_V = r.amplitude_V;
        fr.bias_V = out.plan.bias_V[static_cast<std::size_t>(a)];
        fr.periods = r.periods;
        fr.transient_periods = r.transient_periods;
        const measure::FrfPlan p = plan_frf_device(c, fr, static_cast<uint8_t>(a));
        if (p.layout.period_samples != out.plan.layout.period_samples || p.layout.first_bin != out.plan.layout.first_bin ||
            p.layout.last_bin != out.plan.layout.last_bin)
            throw std::logic_error("the single-axis multisine's lines differ from the n x n plan's");
        ExcitationConfig e = measure::excitation_config(p, fr);
        multisine.push_back(e);
        e.amplitude = 0.0f;  // the bias alone
        e.periods = 0;       // until stopped
        hold.push_back(e);
    }
    const link::StatusReply st = c.status();
    for (int a = 0; a < n; ++a)
        if (st.axis_wave_running[a] || st.axis_excitation_running[a] || st.axis_tripped[a])
            throw std::invalid_argument(std::string("axis ") + "xyz"[a] +
                                        (st.axis_tripped[a] ? " is tripped: clear it (`piezoloop clear-trip`) and set "
                                                              "every axis's limits group"
                                                            : " is running a wave or an excitation: stop it first"));
    if (st.streaming) throw std::invalid_argument("the board is running a setpoint stream: stop it first");

    const std::size_t samples = out.plan.block_samples;
    std::vector<std::vector<std::vector<double>>> u(static_cast<std::size_t>(n)), y(static_cast<std::size_t>(n));
    const auto t0 = std::chrono::steady_clock::now();
    open_loop_axes(c, n, [&] {
        for (int b = 0; b < n; ++b) {
            c.disarm();
            // The held axes first (the first of them arms every axis), then
            // b's multisine with the recorder, at one tick.
            bool armed = false;
            for (int a = 0; a < n; ++a) {
                if (a == b) continue;
                c.start_excitation(hold[static_cast<std::size_t>(a)], armed ? 0 : wave_flag::kArm, static_cast<uint8_t>(a));
                armed = true;
            }
            RecordOptions ro;
            ro.axis = static_cast<uint8_t>(b);
            ro.signals = {kSignalU};
            ro.signal_axes = {static_cast<uint8_t>(b)};
            for (int a = 0; a < n; ++a) {
                ro.signals.push_back(kSignalY);
                ro.signal_axes.push_back(static_cast<uint8_t>(a));
            }
            ro.duration_s = static_cast<double>(samples) / h.loop_rate_Hz;
            ro.excitation = multisine[static_cast<std::size_t>(b)];
            ro.stop_requested = o.stop_requested;
            if (o.progress) ro.progress = [&, b](double f) { o.progress((b + f) / n); };
            RecordResult rec = record(c, ro);
            if (!rec.complete() || rec.frames != samples)
                throw LinkError("block " + std::to_string(b) + ": the recording is incomplete:" + rec.problems());
            const link::StatusReply after = c.status();
            for (int a = 0; a < n; ++a) {
                out.clipped_samples += after.axis_excitation_clipped[a];
                c.stop_excitation(static_cast<uint8_t>(a));
            }
            auto& ub = u[static_cast<std::size_t>(b)];
            auto& yb = y[static_cast<std::size_t>(b)];
            for (int a = 0; a < n; ++a) {
                ub.push_back(a == b ? rec.values[0]
                                    : std::vector<double>(samples, out.plan.bias_V[static_cast<std::size_t>(a)]));
                yb.push_back(rec.values[static_cast<std::size_t>(a) + 1]);
            }
            out.records.push_back(std::move(rec));
        }
    });
    out.wall_s = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
    out.estimate = measure::estimate_mimo_frf(out.plan, u, y);
    return out;
}

nlohmann::json board_mimo_report(Client& c, const DeviceMimoFrfRun& run) {
    nlohmann::json axes = nlohmann::json::array(), blocks = nlohmann::json::array();
    for (int i = 0; i < run.estimate.inputs; ++i) axes.push_back(std::string(1, "xyz"[i]));
    for (const RecordResult& rec : run.records) blocks.push_back(recording_summary(rec));
    nlohmann::json out = measure::mimo_frf_summary(run.estimate);
    out["axes"] = axes;
    out["source"] = {{"kind", "board"}, {"device", c.address()}, {"board", c.info().board.data()}};
    out["design"] = "one axis at a time";
    out["output_matrix"] = "the board's";
    out["clipped_samples"] = run.clipped_samples;
    out["recordings"] = blocks;
    out["wall_s"] = run.wall_s;
    return out;
}

}  // namespace piezoloop::hostlink
