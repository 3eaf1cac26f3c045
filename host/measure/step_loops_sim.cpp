#include "measure/step_loops_sim.hpp"

#include <algorithm>
#include <chrono>
#include <memory>
#include <stdexcept>

#include "piezoloop/pipeline.hpp"
#include "piezoloop/reference_run.hpp"
#include "sim/build_case.hpp"
#include "sim/loop_kernel.hpp"
#include "status_text.hpp"
#include "options/option_checks.hpp"

namespace piezoloop::measure {

namespace {

using options::refuse;

[[noreturn]] void fail(const char* what, const Status& st) {
    throw std::invalid_argument(std::string(what) + ": " + describe(st));
}

// Steps and loops need no multisine table: a small excitation capacity keeps
// the pipeline's footprint down.
template <class T>
using ShapePipeline = Pipeline<T, sim::kSimRcCapacity, 4, 1024, 4>;

// Open loop: the stage alone, the case lending only its hysteresis override
// and sample type (as measure frf). Closed loop: the case as built for `sim`.
sim::LoopModel loop_model(const sim::Scenario& s, const sim::CaseSpec* c, bool closed) {
    sim::LoopModel m;
    if (closed) {
        if (!c) refuse("--case", "closed loop needs the case whose controller closes it");
        sim::BuildOptions bo;
        bo.check_realisation = false;
        return sim::build_case(s, *c, bo).model;
    }
    sim::build_stage(s, c, 10, m);
    m.setup = s.setup;
    m.params = PipelineParams{};
    m.params.limits = s.limits;
    m.sample = c ? c->sample : sim::SampleType::kFloat;
    return m;
}

struct Recorded {
    std::vector<double> r, y, u;
    uint32_t clipped = 0;
    std::string trip = "none";
    uint64_t hash = 0;
    double wall_s = 0.0;
};

// Runs `ticks` ticks from rest; before tick k, `before(k, pipe)` may start
// the next excitation. Every tick is recorded.
template <class T, class Before>
Recorded run(const sim::LoopModel& m, uint64_t ticks, Before&& before, const std::function<void(double)>& progress,
             sim::CarriedStage* carried) {
    auto pipe = std::make_unique<ShapePipeline<T>>(m.setup);
    if (const Status st = pipe->stage(m.params); !st.ok()) fail("controller", st);
    StageModel stage;
    StageConfig sc = m.stage;
    sc.rate_Hz = m.setup.rate_Hz;
    if (const Status st = stage.configure(sc); !st.ok()) fail("plant", st);
    Recorded rec;
    rec.r.reserve(ticks);
    rec.y.reserve(ticks);
    rec.u.reserve(ticks);
    const uint64_t progress_every = uint64_t{1} << 15;
    auto observe = [&](const sim::TickView& v, const TickSignals<T>&, const StageModel&) {
        rec.r.push_back(v.r_um);
        rec.y.push_back(v.y_um);
        rec.u.push_back(v.u_V);
        if (progress && (v.k + 1) % progress_every == 0)
            progress(static_cast<double>(v.k + 1) / static_cast<double>(ticks));
    };
    reference::LogHash hash;
    sim::LoopKernel<T, ShapePipeline<T>, StageModel> loop(*pipe, stage, m.stage.sensor.gain, &hash);
    loop.carry_in(carried);
    pipe->arm();
    const auto t0 = std::chrono::steady_clock::now();
    for (uint64_t k = 0; k < ticks; ++k) {
        before(k, *pipe);
        loop.step(k, observe);
    }
    rec.wall_s = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
    if (progress) progress(1.0);
    loop.carry_out(carried);
    rec.clipped = pipe->limiter().clamped_samples() + pipe->limiter().slew_limited_samples();
    rec.trip = trip_reason_name(pipe->limiter().trip_reason());
    rec.hash = hash.value();
    return rec;
}

template <class Go>
Recorded run_sample(const sim::LoopModel& m, Go&& go) {
    return m.sample == sim::SampleType::kQ31 ? go.template operator()<Q31>() : go.template operator()<float>();
}

// Samples at the end of the sensor's ADC range, in runs of 3 or more: the
// reading stops there while the stage moves on, so a loop or a step there is
// the sensor's, not the stage's (the ADC clamps, stage_model.hpp). Shorter
// runs are the stage at rest at the range's end with its noise clamped (and
// the loop's first reading, y_0 = 0), not a stage beyond it.
uint32_t sensor_saturated(const sim::Scenario& s, const std::vector<double>& y_um) {
    const double g = s.plant.sensor.gain;
    if (!(g > 0.0)) return 0;
    const double lo = s.plant.adc.min / g, hi = s.plant.adc.max / g;
    const double tol = 1e-6 * (hi - lo);  // the reading is a float
    uint32_t n = 0, run = 0;
    for (std::size_t k = 0; k <= y_um.size(); ++k) {
        if (k < y_um.size() && (y_um[k] <= lo + tol || y_um[k] >= hi - tol)) {
            ++run;
            continue;
        }
        if (run >= 3) n += run;
        run = 0;
    }
    return n;
}

void warn_saturation(const sim::Scenario& s, const std::vector<double>& y_um, std::vector<std::string>& warnings) {
    if (const uint32_t n = sensor_saturated(s, y_um); n > 0)
        warnings.push_back(std::to_string(n) + " samples read at the end of the sensor's ADC range: the stage went "
                           "beyond what the sensor reads there; lower the amplitude");
}

}  // namespace

MeasureBounds scenario_bounds(const sim::Scenario& s) {
    MeasureBounds b;
    b.rate_Hz = s.rate_Hz;
    b.limits = s.limits;
    b.whose = "scenario's";
    const double k = s.command_um_per_V();
    RangeUm r{s.limits.u_min_V * k, s.limits.u_max_V * k};
    if (k < 0.0) std::swap(r.min_um, r.max_um);
    const double g = s.plant.sensor.gain;
    if (g > 0.0) {
        r.min_um = std::max(r.min_um, static_cast<double>(s.plant.adc.min) / g);
        r.max_um = std::min(r.max_um, static_cast<double>(s.plant.adc.max) / g);
    }
    const double fs = s.setup.position.full_scale;
    r.min_um = std::max(r.min_um, -fs);
    r.max_um = std::min(r.max_um, fs);
    b.closed_range = r;
    return b;
}

StepRun run_step_sim(const sim::Scenario& s, const sim::CaseSpec* case_spec, const StepRequest& r,
                     const std::function<void(double)>& progress, sim::CarriedStage* carried) {
    StepRun out;
    out.plan = plan_step(scenario_bounds(s), r);
    const sim::LoopModel m = loop_model(s, case_spec, r.closed);
    // Closed loop the setpoint is `from` from the start; d adds the step.
    const ExcitationConfig exc = step_excitation(out.plan, r, s.rate_Hz, r.from);
    const uint64_t ticks = out.plan.hold_ticks + out.plan.post_ticks;
    const Recorded rec = run_sample(m, [&]<class T>() {
        auto before = [&](uint64_t k, ShapePipeline<T>& pipe) {
            if (k != 0) return;
            if (r.closed) (void)pipe.set_setpoint(m.setup.position.to_sample<T>(static_cast<float>(r.from)));
            if (const Status st = pipe.start_excitation(exc); !st.ok()) fail("step", st);
        };
        return run<T>(m, ticks, before, progress, carried);
    });
    out.clipped_samples = rec.clipped;
    out.trip = rec.trip;
    out.log_hash = rec.hash;
    out.wall_s = rec.wall_s;
    analyse_step_run(rec.r, rec.y, rec.u, s.rate_Hz, out);
    warn_saturation(s, out.y_um, out.warnings);
    return out;
}

LoopsRun run_loops_sim(const sim::Scenario& s, const sim::CaseSpec* case_spec, const LoopsRequest& r,
                       const std::function<void(double)>& progress, sim::CarriedStage* carried) {
    LoopsRun out;
    out.plan = plan_loops(scenario_bounds(s), r);
    const sim::LoopModel m = loop_model(s, case_spec, false);
    const uint64_t per = out.plan.amplitude_ticks;
    // The amplitudes back to back: each starts at the tick after the last
    // one ended.
    const Recorded rec = run_sample(m, [&]<class T>() {
        auto before = [&](uint64_t k, ShapePipeline<T>& pipe) {
            if (k % per != 0) return;
            const ExcitationConfig c = loop_excitation(out.plan, r, static_cast<std::size_t>(k / per), s.rate_Hz);
            if (const Status st = pipe.start_excitation(c); !st.ok()) fail("loops", st);
        };
        return run<T>(m, out.plan.ticks, before, progress, carried);
    });
    std::vector<std::vector<double>> u, y;
    for (std::size_t j = 0; j < r.amplitudes_V.size(); ++j) {
        const auto b = static_cast<std::ptrdiff_t>(j * per), e = static_cast<std::ptrdiff_t>((j + 1) * per);
        u.emplace_back(rec.u.begin() + b, rec.u.begin() + e);
        y.emplace_back(rec.y.begin() + b, rec.y.begin() + e);
    }
    out.clipped_samples = rec.clipped;
    out.trip = rec.trip;
    out.log_hash = rec.hash;
    out.wall_s = rec.wall_s;
    analyse_loops_run(r, s.rate_Hz, u, y, out);
    warn_saturation(s, out.y_um, out.warnings);
    return out;
}

}  // namespace piezoloop::measure
