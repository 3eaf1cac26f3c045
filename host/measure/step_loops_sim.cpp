#include "measure/step_loops_sim.hpp"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <memory>
#include <numbers>
#include <stdexcept>

#include "format/number.hpp"
#include "piezoloop/excitation.hpp"
#include "piezoloop/pipeline.hpp"
#include "piezoloop/reference_run.hpp"
#include "sim/build_case.hpp"
#include "sim/loop_kernel.hpp"
#include "sim/metrics.hpp"
#include "status_text.hpp"

namespace piezoloop::measure {

namespace {

std::string num(double x) { return format::significant(x, 6); }

[[noreturn]] void refuse(const std::string& option, const std::string& why) {
    throw std::invalid_argument(option + ": " + why);
}

// Longest record either command keeps: bounds memory (a few doubles per tick,
// ~100 MB at this count) and wall time; in ticks, since a 100 kHz scenario
// fills it ten times faster than a 10 kHz one.
constexpr uint64_t kMaxRecordTicks = 2'000'000;

// The streamed command needs no table: a small excitation capacity keeps the
// pipeline's footprint down.
template <class T>
using StreamPipeline = Pipeline<T, sim::kSimRcCapacity, 4, 1024, 4>;

[[noreturn]] void fail(const char* what, const Status& st) {
    throw std::invalid_argument(std::string(what) + ": " + describe(st));
}

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

// One tick of command through the excitation (see the header): amplitude 0,
// the command as the offset, stopped as soon as started.
template <class T, class PipelineT>
void stream_command(PipelineT& pipe, const sim::LoopModel& m, double command_V) {
    ExcitationConfig c;
    c.signal = ExcitationSignal::kPrbs;  // no table to build; w is irrelevant at amplitude 0
    c.point = ExcitationPoint::kCommand;
    c.prbs_order = 2;
    c.amplitude = 0.0f;
    c.offset = static_cast<float>(command_V);
    c.sample_rate_Hz = m.setup.rate_Hz;
    if (const Status st = pipe.start_excitation(c); !st.ok()) fail("command", st);
    pipe.stop_excitation();
}

struct Recorded {
    std::vector<double> r, y, u;
    uint32_t clipped = 0;
    std::string trip = "none";
    uint64_t hash = 0;
    double wall_s = 0.0;
};

// Runs `ticks` ticks; before tick k, `before(k, pipe)` sets the command or the
// setpoint; ticks from record_from on are recorded.
template <class T, class Before>
Recorded run(const sim::LoopModel& m, uint64_t ticks, uint64_t record_from, Before&& before,
             const std::function<void(double)>& progress) {
    auto pipe = std::make_unique<StreamPipeline<T>>(m.setup);
    if (const Status st = pipe->stage(m.params); !st.ok()) fail("controller", st);
    StageModel stage;
    StageConfig sc = m.stage;
    sc.rate_Hz = m.setup.rate_Hz;
    if (const Status st = stage.configure(sc); !st.ok()) fail("plant", st);
    Recorded rec;
    const std::size_t n = static_cast<std::size_t>(ticks - record_from);
    rec.r.reserve(n);
    rec.y.reserve(n);
    rec.u.reserve(n);
    auto clip_count = [&] { return pipe->limiter().clamped_samples() + pipe->limiter().slew_limited_samples(); };
    uint32_t clip_at_start = 0;
    const uint64_t progress_every = uint64_t{1} << 15;
    auto observe = [&](const sim::TickView& v, const TickSignals<T>&, const StageModel&) {
        if (v.k + 1 == record_from) clip_at_start = clip_count();
        if (v.k >= record_from) {
            rec.r.push_back(v.r_um);
            rec.y.push_back(v.y_um);
            rec.u.push_back(v.u_V);
        }
        if (progress && (v.k + 1) % progress_every == 0)
            progress(static_cast<double>(v.k + 1) / static_cast<double>(ticks));
    };
    reference::LogHash hash;
    sim::LoopKernel<T, StreamPipeline<T>, StageModel> loop(*pipe, stage, m.stage.sensor.gain, &hash);
    pipe->arm();
    const auto t0 = std::chrono::steady_clock::now();
    for (uint64_t k = 0; k < ticks; ++k) {
        before(k, *pipe);
        loop.step(k, observe);
    }
    rec.wall_s = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
    if (progress) progress(1.0);
    rec.clipped = clip_count() - clip_at_start;
    rec.trip = trip_reason_name(pipe->limiter().trip_reason());
    rec.hash = hash.value();
    return rec;
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

std::string saturation_warning(uint32_t n) {
    return std::to_string(n) + " samples read at the end of the sensor's ADC range: the stage went beyond what "
           "the sensor reads there; lower the amplitude";
}

// Recorded after the step, and held as long before it.
void check_duration(const sim::Scenario& s, double duration_s, const char* option) {
    const double max_s = static_cast<double>(kMaxRecordTicks / 2) / s.rate_Hz;
    if (!std::isfinite(duration_s) || !(duration_s > 0.0) || duration_s > max_s)
        refuse(option, "must be in (0, " + num(max_s) + "] s (" + std::to_string(kMaxRecordTicks / 2) +
                           " ticks at the scenario's rate)");
}

}  // namespace

RangeUm closed_loop_range(const sim::Scenario& s) {
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
    return r;
}

StepPlan plan_step(const sim::Scenario& s, const StepRequest& r) {
    check_duration(s, r.duration_s, "--duration-s");
    const char* step_opt = r.closed ? "--step-um" : "--step-v";
    const char* from_opt = r.closed ? "--from-um" : "--bias-v";
    if (!std::isfinite(r.step) || r.step == 0.0) refuse(step_opt, "must be finite and non-zero");
    if (!std::isfinite(r.from)) refuse(from_opt, "must be finite");
    double lo = s.limits.u_min_V, hi = s.limits.u_max_V;
    std::string what = "the scenario's command limits";
    std::string unit = " V";
    if (r.closed) {
        const RangeUm range = closed_loop_range(s);
        lo = range.min_um;
        hi = range.max_um;
        what = "the range the loop can hold (command limits at the mean slope, the sensor's ADC, the position scale)";
        unit = " um";
    }
    const std::string range = "[" + num(lo) + ", " + num(hi) + "]" + unit;
    if (r.from < lo || r.from > hi) refuse(from_opt, "must be within " + what + " " + range);
    const double to = r.from + r.step;
    if (to < lo || to > hi)
        refuse(step_opt, "from " + num(r.from) + unit + " the step must end within " + what + " " + range +
                             ": between " + num(lo - r.from) + " and " + num(hi - r.from) + unit);
    StepPlan p;
    p.post_ticks = static_cast<uint64_t>(std::llround(r.duration_s * s.rate_Hz));
    if (p.post_ticks < 10) refuse("--duration-s", "must hold at least 10 loop ticks (" + num(10.0 / s.rate_Hz) + " s)");
    p.hold_ticks = p.post_ticks;
    p.pre_record = std::max<uint64_t>(1, p.post_ticks / 10);
    return p;
}

StepRun run_step_sim(const sim::Scenario& s, const sim::CaseSpec* case_spec, const StepRequest& r,
                     const std::function<void(double)>& progress) {
    const StepPlan plan = plan_step(s, r);
    const sim::LoopModel m = loop_model(s, case_spec, r.closed);
    const uint64_t ticks = plan.hold_ticks + plan.post_ticks;
    const uint64_t record_from = plan.hold_ticks - plan.pre_record;
    auto go = [&]<class T>() {
        auto before = [&](uint64_t k, StreamPipeline<T>& pipe) {
            const double level = k < plan.hold_ticks ? r.from : r.from + r.step;
            if (r.closed) {
                if (k == 0 || k == plan.hold_ticks)
                    (void)pipe.set_setpoint(m.setup.position.to_sample<T>(static_cast<float>(level)));
            } else {
                stream_command<T>(pipe, m, level);
            }
        };
        return run<T>(m, ticks, record_from, before, progress);
    };
    const Recorded rec = m.sample == sim::SampleType::kQ31 ? go.template operator()<Q31>()
                                                           : go.template operator()<float>();
    StepRun out;
    out.plan = plan;
    out.r_um = rec.r;
    out.y_um = rec.y;
    out.u_V = rec.u;
    const double ts = 1.0 / s.rate_Hz;
    out.time_s.resize(rec.y.size());
    for (std::size_t i = 0; i < rec.y.size(); ++i)
        out.time_s[i] = (static_cast<double>(i) - static_cast<double>(plan.pre_record)) * ts;
    out.figures = analyse_step(out.y_um, ts, plan.pre_record);
    out.clipped_samples = rec.clipped;
    out.trip = rec.trip;
    out.log_hash = rec.hash;
    out.wall_s = rec.wall_s;
    if (!out.figures.settled)
        out.warnings.push_back("the response has not settled within 2 % by the end of the record: raise --duration-s");
    if (rec.clipped > 0)
        out.warnings.push_back("the limiter clamped or slew-limited " + std::to_string(rec.clipped) +
                               " samples of the record: the step is shaped by the limits there");
    if (rec.trip != "none") out.warnings.push_back("the limiter tripped (" + rec.trip + "): the output went to safe");
    if (const uint32_t sat = sensor_saturated(s, out.y_um); sat > 0) out.warnings.push_back(saturation_warning(sat));
    return out;
}

// ---------------------------------------------------------------- loops

LoopsPlan plan_loops(const sim::Scenario& s, const LoopsRequest& r) {
    if (r.amplitudes_V.empty()) refuse("--amplitudes-v", "needs at least one amplitude");
    if (r.shape != "triangle" && r.shape != "sine") refuse("--shape", "must be triangle or sine");
    if (!std::isfinite(r.base_V) || r.base_V < s.limits.u_min_V || r.base_V > s.limits.u_max_V)
        refuse("--bias-v", "must be within the scenario's command limits [" + num(s.limits.u_min_V) + ", " +
                               num(s.limits.u_max_V) + "] V");
    const double room = s.limits.u_max_V - r.base_V;
    for (const double a : r.amplitudes_V)
        if (!std::isfinite(a) || !(a > 0.0) || a > room)
            refuse("--amplitudes-v", "each must be in (0, " + num(room) + "] V: from the base " + num(r.base_V) +
                                         " V the loop must stay within the scenario's command limits [" +
                                         num(s.limits.u_min_V) + ", " + num(s.limits.u_max_V) + "] V (got " +
                                         num(a) + ")");
    if (r.cycles < 1 || r.cycles > 100) refuse("--cycles", "must be in [1, 100]");
    // At least 20 ticks a cycle, so the turning points are resolved.
    const double f_max = s.rate_Hz / 20.0;
    if (!std::isfinite(r.frequency_Hz) || !(r.frequency_Hz > 0.0) || r.frequency_Hz > f_max)
        refuse("--frequency-hz", "must be in (0, rate / 20 = " + num(f_max) + "] Hz");
    LoopsPlan p;
    p.cycle_ticks = static_cast<uint64_t>(std::llround(s.rate_Hz / r.frequency_Hz));
    p.ticks = p.cycle_ticks * static_cast<uint64_t>(r.cycles) * r.amplitudes_V.size();
    const double max_s = static_cast<double>(kMaxRecordTicks) / s.rate_Hz;
    if (p.ticks > kMaxRecordTicks)
        refuse("--frequency-hz", "amplitudes x cycles / frequency must be at most " + num(max_s) +
                                     " s simulated (got " + num(static_cast<double>(p.ticks) / s.rate_Hz) + " s)");
    return p;
}

double loop_max_width_pct(const std::vector<double>& input, const std::vector<double>& output) {
    if (input.size() != output.size() || input.size() < 4) return -1.0;
    const std::size_t top = static_cast<std::size_t>(std::max_element(input.begin(), input.end()) - input.begin());
    if (top == 0 || top + 1 >= input.size()) return -1.0;
    const auto [ymin, ymax] = std::minmax_element(output.begin(), output.end());
    if (!(*ymax > *ymin)) return -1.0;
    // Output of a branch [from, to] at input level v: first segment spanning v.
    auto at = [&](std::size_t from, std::size_t to, double v, double& x) {
        for (std::size_t k = from; k < to; ++k) {
            const double a = input[k], b = input[k + 1];
            if ((a <= v && v <= b) || (b <= v && v <= a)) {
                x = a == b ? output[k] : output[k] + (v - a) / (b - a) * (output[k + 1] - output[k]);
                return true;
            }
        }
        return false;
    };
    const double lo = std::max(*std::min_element(input.begin(), input.begin() + top + 1),
                               *std::min_element(input.begin() + top, input.end()));
    const double hi = input[top];
    constexpr int kLevels = 200;
    double widest = 0.0;
    for (int i = 0; i <= kLevels; ++i) {
        const double v = lo + (hi - lo) * i / kLevels;
        double up = 0.0, down = 0.0;
        if (at(0, top, v, up) && at(top, input.size() - 1, v, down)) widest = std::max(widest, std::fabs(up - down));
    }
    return 100.0 * widest / (*ymax - *ymin);
}

LoopsRun run_loops_sim(const sim::Scenario& s, const sim::CaseSpec* case_spec, const LoopsRequest& r,
                       const std::function<void(double)>& progress) {
    const LoopsPlan plan = plan_loops(s, r);
    const sim::LoopModel m = loop_model(s, case_spec, false);
    const uint64_t per_amplitude = plan.cycle_ticks * static_cast<uint64_t>(r.cycles);
    const bool sine = r.shape == "sine";
    auto command = [&](uint64_t k) {
        const double a = r.amplitudes_V[static_cast<std::size_t>(k / per_amplitude)];
        const double phase = static_cast<double>(k % plan.cycle_ticks) / static_cast<double>(plan.cycle_ticks);
        const double w = sine ? 0.5 * (1.0 - std::cos(2.0 * std::numbers::pi * phase)) : 1.0 - std::fabs(1.0 - 2.0 * phase);
        return r.base_V + a * w;
    };
    auto go = [&]<class T>() {
        auto before = [&](uint64_t k, StreamPipeline<T>& pipe) { stream_command<T>(pipe, m, command(k)); };
        return run<T>(m, plan.ticks, 0, before, progress);
    };
    const Recorded rec = m.sample == sim::SampleType::kQ31 ? go.template operator()<Q31>()
                                                           : go.template operator()<float>();
    LoopsRun out;
    out.plan = plan;
    // The reading at tick k + 1 is the first that the command of tick k moved
    // (the loop's tick of delay): pair them, so that the arrays and the CSV
    // hold (u_k, y_k+1) -- the static map identify pi and dahl fit.
    const std::size_t n = rec.y.size() - 1;
    out.u_V.assign(rec.u.begin(), rec.u.begin() + static_cast<std::ptrdiff_t>(n));
    out.y_um.assign(rec.y.begin() + 1, rec.y.end());
    out.time_s.resize(n);
    out.amplitude_V.resize(n);
    for (std::size_t i = 0; i < n; ++i) {
        out.time_s[i] = static_cast<double>(i) / s.rate_Hz;
        out.amplitude_V[i] = r.amplitudes_V[i / per_amplitude];
    }
    // The last cycle of each amplitude.
    for (std::size_t j = 0; j < r.amplitudes_V.size(); ++j) {
        const std::size_t end = std::min(n, (j + 1) * per_amplitude), begin = (j + 1) * per_amplitude - plan.cycle_ticks;
        const std::vector<double> u(out.u_V.begin() + static_cast<std::ptrdiff_t>(begin),
                                    out.u_V.begin() + static_cast<std::ptrdiff_t>(end));
        const std::vector<double> y(out.y_um.begin() + static_cast<std::ptrdiff_t>(begin),
                                    out.y_um.begin() + static_cast<std::ptrdiff_t>(end));
        LoopFigures f;
        f.amplitude_V = r.amplitudes_V[j];
        f.hysteresis_pct = sim::hysteresis_pct(u, y);
        f.max_width_pct = loop_max_width_pct(u, y);
        const auto [ymin, ymax] = std::minmax_element(y.begin(), y.end());
        f.y_min_um = *ymin;
        f.y_max_um = *ymax;
        out.loops.push_back(f);
    }
    out.clipped_samples = rec.clipped;
    out.trip = rec.trip;
    out.log_hash = rec.hash;
    out.wall_s = rec.wall_s;
    if (r.cycles < 2)
        out.warnings.push_back("one cycle per amplitude: the measured cycle includes the transient from the previous "
                               "amplitude; use --cycles >= 2");
    if (rec.clipped > 0)
        out.warnings.push_back("the limiter clamped or slew-limited " + std::to_string(rec.clipped) +
                               " samples: the loops are shaped by the limits there");
    if (rec.trip != "none") out.warnings.push_back("the limiter tripped (" + rec.trip + "): the output went to safe");
    if (const uint32_t sat = sensor_saturated(s, out.y_um); sat > 0) out.warnings.push_back(saturation_warning(sat));
    return out;
}

}  // namespace piezoloop::measure
