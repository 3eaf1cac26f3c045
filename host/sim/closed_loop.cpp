#include "sim/closed_loop.hpp"

#include <chrono>
#include <cmath>
#include <memory>
#include <stdexcept>
#include <string>

#include "piezoloop/reference_run.hpp"
#include "sim/loop_kernel.hpp"
#include "sim/window_metrics.hpp"
#include "status_text.hpp"

namespace piezoloop::sim {

const char* to_string(Fidelity f) { return f == Fidelity::kDouble ? "double" : "float"; }
const char* to_string(SampleType s) { return s == SampleType::kQ31 ? "q31" : "float"; }

namespace {

[[noreturn]] void reject(const char* what, const Status& s) {
    std::string text(what);
    text += ": ";
    text += describe(s);
    throw std::invalid_argument(text);
}

template <class T, class Stage>
RunResult run_with(const LoopModel& m, const RunOptions& o, Stage& stage) {
    using PipelineT = Pipeline<T, kSimRcCapacity>;
    auto pipe = std::make_unique<PipelineT>(m.setup);
    if (const Status s = pipe->limiter().hard_status(); !s.ok()) reject("setup.hard", s);
    if (const Status s = pipe->stage(m.params); !s.ok()) reject("controller", s);
    TrajectoryConfig wave = o.wave;
    wave.sample_rate_Hz = m.setup.rate_Hz;
    if (!o.table.empty()) wave.table = o.table;
    if (const Status s = pipe->start_wave(wave); !s.ok()) reject("trajectory", s);
    pipe->arm();

    const SignalScale volt = m.setup.voltage;
    reference::LogHash hash;
    WindowMetrics window(o.window_midpoint_um);
    RunResult res;
    double period_sq = 0.0;
    uint64_t period_n = 0;
    const uint64_t progress_every = uint64_t{1} << 16;

    // Tone: a phasor rotated by one tick's angle each tick, renormalised now
    // and then (its magnitude drifts by rounding only).
    const double tone_w = 2.0 * M_PI * o.tone_Hz / static_cast<double>(m.setup.rate_Hz);
    const std::complex<double> tone_step = std::polar(1.0, -tone_w);
    std::complex<double> phasor = 1.0, acc_r = 0.0, acc_y = 0.0;
    uint64_t tone_n = 0;

    // u_fb is a voltage, or in series placement a displacement correction.
    const SignalScale fb_scale =
        m.params.feedforward == FeedforwardKind::kPiSeries ? m.setup.position : m.setup.voltage;

    auto observe = [&](const TickView& v, const TickSignals<T>& sig, const Stage& st) {
        const uint64_t k = v.k;
        if (k >= o.window_start) {
            window.add(v.r_um, v.y_um);
            if (o.tone_Hz > 0.0) {
                if (tone_n == 0) phasor = std::polar(1.0, -tone_w * static_cast<double>(k));
                acc_r += static_cast<double>(v.r_um) * phasor;
                acc_y += static_cast<double>(v.y_um) * phasor;
                phasor *= tone_step;
                if (++tone_n % 4096 == 0) phasor /= std::abs(phasor);
            }
        }
        if (o.period_ticks != 0 && k >= o.approach_ticks) {
            const double e = static_cast<double>(v.r_um) - static_cast<double>(v.y_um);
            period_sq += e * e;
            if (++period_n == o.period_ticks) {
                res.period_e_rms_um.push_back(std::sqrt(period_sq / static_cast<double>(period_n)));
                period_sq = 0.0;
                period_n = 0;
            }
        }
        if (o.log_every != 0 && k >= o.log_start && (k - o.log_start) % o.log_every == 0) {
            RunLog& l = res.log;
            l.tick.push_back(k);
            l.r_um.push_back(v.r_um);
            l.y_um.push_back(v.y_um);
            l.u_V.push_back(v.u_V);
            l.u_ff_V.push_back(volt.to_physical(sig.u_ff));
            l.u_fb_V.push_back(fb_scale.to_physical(sig.u_fb));
            l.v_piezo_V.push_back(static_cast<float>(st.piezo_voltage_V()));
            l.x_um.push_back(static_cast<float>(st.displacement_um()));
        }
        if (o.progress && (k + 1) % progress_every == 0)
            o.progress(static_cast<double>(k + 1) / static_cast<double>(o.ticks));
    };

    const auto t0 = std::chrono::steady_clock::now();
    run_ticks<T>(*pipe, stage, m.stage.sensor.gain, o.ticks, o.hash ? &hash : nullptr, observe, o.carried);
    const auto t1 = std::chrono::steady_clock::now();
    res.wall_s = std::chrono::duration<double>(t1 - t0).count();
    res.ticks = o.ticks;
    res.simulated_s = static_cast<double>(o.ticks) / static_cast<double>(m.setup.rate_Hz);
    res.realtime_factor = res.wall_s > 0.0 ? res.simulated_s / res.wall_s : 0.0;
    res.log_hash = hash.value();
    res.tracking = window.tracking();
    res.hysteresis_pct = window.hysteresis_pct();
    if (tone_n > 0) {
        res.tone_r = acc_r * (2.0 / static_cast<double>(tone_n));
        res.tone_y = acc_y * (2.0 / static_cast<double>(tone_n));
    }
    res.trip = pipe->limiter().trip_reason();
    res.clamped_samples = pipe->limiter().clamped_samples();
    if (o.progress) o.progress(1.0);
    return res;
}

template <class T>
RunResult run_sample(const LoopModel& m, const RunOptions& o) {
    if (o.fidelity == Fidelity::kFloat) {
        StageModel stage;
        StageConfig sc = m.stage;
        sc.rate_Hz = m.setup.rate_Hz;
        if (const Status s = stage.configure(sc); !s.ok()) reject("plant", s);
        return run_with<T>(m, o, stage);
    }
    DoubleStage stage;
    DoubleStageConfig dc = m.stage_double;
    dc.rate_Hz = m.setup.rate_Hz;
    stage.configure(dc);
    return run_with<T>(m, o, stage);
}

template <class T>
uint64_t approach_ticks_in(const LoopModel& m, const RunOptions& o, float from_um) {
    TrajectoryGenerator<T> wave(m.setup.position);
    TrajectoryConfig c = o.wave;
    c.sample_rate_Hz = m.setup.rate_Hz;
    if (!o.table.empty()) c.table = o.table;
    if (const Status s = wave.configure(c); !s.ok()) reject("trajectory", s);
    const uint32_t n = Approach<T>(m.setup.position, m.setup.rate_Hz)
                           .ticks_for(m.setup.position.to_sample<T>(from_um), wave.start_value());
    return n <= 1 ? 0 : n - 1;  // samples 1 .. N-1 come before the wave's first
}

}  // namespace

uint64_t approach_ticks(const LoopModel& model, const RunOptions& options, float from_um) {
    return model.sample == SampleType::kQ31 ? approach_ticks_in<Q31>(model, options, from_um)
                                            : approach_ticks_in<float>(model, options, from_um);
}

void make_room_for_approach(const LoopModel& model, RunOptions& o, float from_um) {
    const uint64_t n = approach_ticks(model, o, from_um);
    o.approach_ticks = n;
    o.ticks += n;
    o.window_start += n;
    if (o.log_start != 0) o.log_start += n;
}

RunResult run_loop(const LoopModel& model, const RunOptions& options) {
    if (options.window_start >= options.ticks && options.ticks != 0)
        throw std::invalid_argument("run: window_start must be < ticks");
    if (model.stage.sensor.gain == 0.0f) throw std::invalid_argument("plant.sensor.gain: must be non-zero");
    return model.sample == SampleType::kQ31 ? run_sample<Q31>(model, options) : run_sample<float>(model, options);
}

}  // namespace piezoloop::sim
