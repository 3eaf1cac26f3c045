#include "measure/step_loops_plan.hpp"

#include <algorithm>
#include <cmath>
#include <stdexcept>

#include "format/number.hpp"
#include "sim/metrics.hpp"
#include "options/option_checks.hpp"

namespace piezoloop::measure {

namespace {

std::string num(double x) { return format::significant(x, 6); }

using options::refuse;

// Recorded after the step, and held as long before it.
void check_duration(const MeasureBounds& b, double duration_s, const char* option) {
    const double max_s = static_cast<double>(kMaxRecordTicks / 2) / b.rate_Hz;
    if (!std::isfinite(duration_s) || !(duration_s > 0.0) || duration_s > max_s)
        refuse(option, "must be in (0, " + num(max_s) + "] s (" + std::to_string(kMaxRecordTicks / 2) +
                           " ticks at the " + b.whose + " rate)");
}

void limiter_warnings(uint32_t clipped, const std::string& trip, const std::string& shaped,
                      std::vector<std::string>& warnings) {
    if (clipped > 0)
        warnings.push_back("the limiter clamped or slew-limited " + std::to_string(clipped) + " samples: " + shaped);
    if (trip != "none") warnings.push_back("the limiter tripped (" + trip + "): the output went to safe");
}

}  // namespace

// ---------------------------------------------------------------- step

StepPlan plan_step(const MeasureBounds& b, const StepRequest& r) {
    check_duration(b, r.duration_s, "--duration-s");
    const char* step_opt = r.closed ? "--step-um" : "--step-v";
    const char* from_opt = r.closed ? "--from-um" : "--bias-v";
    if (!std::isfinite(r.step) || r.step == 0.0) refuse(step_opt, "must be finite and non-zero");
    if (!std::isfinite(r.from)) refuse(from_opt, "must be finite");
    double lo = b.limits.u_min_V, hi = b.limits.u_max_V;
    std::string what = "the " + b.whose + " command limits";
    std::string unit = " V";
    if (r.closed) {
        lo = b.closed_range.min_um;
        hi = b.closed_range.max_um;
        what = "the range the " + b.whose + " loop can hold";
        unit = " um";
    }
    const std::string range = "[" + num(lo) + ", " + num(hi) + "]" + unit;
    if (r.from < lo || r.from > hi) refuse(from_opt, "must be within " + what + " " + range);
    const double to = r.from + r.step;
    if (to < lo || to > hi)
        refuse(step_opt, "from " + num(r.from) + unit + " the step must end within " + what + " " + range +
                             ": between " + num(lo - r.from) + " and " + num(hi - r.from) + unit);
    StepPlan p;
    p.post_ticks = static_cast<uint64_t>(std::llround(r.duration_s * b.rate_Hz));
    if (p.post_ticks < 10) refuse("--duration-s", "must hold at least 10 loop ticks (" + num(10.0 / b.rate_Hz) + " s)");
    p.hold_ticks = p.post_ticks;
    p.pre_record = std::max<uint64_t>(1, p.post_ticks / 10);
    return p;
}

ExcitationConfig step_excitation(const StepPlan& p, const StepRequest& r, double rate_Hz, double held_setpoint_um) {
    ExcitationConfig c;
    c.signal = ExcitationSignal::kStep;
    c.point = r.closed ? ExcitationPoint::kReference : ExcitationPoint::kCommand;
    c.offset = static_cast<float>(r.closed ? r.from - held_setpoint_um : r.from);
    c.amplitude = static_cast<float>(r.step);
    c.sample_rate_Hz = static_cast<float>(rate_Hz);
    c.period_samples = static_cast<uint32_t>(p.hold_ticks + p.post_ticks);
    c.periods = 1;
    return c;
}

void analyse_step_run(const std::vector<double>& r_um, const std::vector<double>& y_um,
                      const std::vector<double>& u_V, double rate_Hz, StepRun& run) {
    const StepPlan& plan = run.plan;
    const auto from = static_cast<std::ptrdiff_t>(plan.hold_ticks - plan.pre_record);
    const auto to = static_cast<std::ptrdiff_t>(plan.hold_ticks + plan.post_ticks);
    if (static_cast<std::ptrdiff_t>(y_um.size()) < to || r_um.size() != y_um.size() || u_V.size() != y_um.size())
        throw std::invalid_argument("step: the recording is shorter than the step");
    run.r_um.assign(r_um.begin() + from, r_um.begin() + to);
    run.y_um.assign(y_um.begin() + from, y_um.begin() + to);
    run.u_V.assign(u_V.begin() + from, u_V.begin() + to);
    const double ts = 1.0 / rate_Hz;
    run.time_s.resize(run.y_um.size());
    for (std::size_t i = 0; i < run.y_um.size(); ++i)
        run.time_s[i] = (static_cast<double>(i) - static_cast<double>(plan.pre_record)) * ts;
    run.figures = analyse_step(run.y_um, ts, plan.pre_record);
    if (!run.figures.settled)
        run.warnings.push_back("the response has not settled within 2 % by the end of the record: raise --duration-s");
    limiter_warnings(run.clipped_samples, run.trip, "the step is shaped by the limits there", run.warnings);
}

// ---------------------------------------------------------------- loops

LoopsPlan plan_loops(const MeasureBounds& b, const LoopsRequest& r) {
    const LimitsConfig& lim = b.limits;
    if (r.amplitudes_V.empty()) refuse("--amplitudes-v", "needs at least one amplitude");
    if (r.shape != "triangle" && r.shape != "sine") refuse("--shape", "must be triangle or sine");
    if (!std::isfinite(r.base_V) || r.base_V < lim.u_min_V || r.base_V > lim.u_max_V)
        refuse("--bias-v", "must be within the " + b.whose + " command limits [" + num(lim.u_min_V) + ", " +
                               num(lim.u_max_V) + "] V");
    const double room = lim.u_max_V - r.base_V;
    for (const double a : r.amplitudes_V)
        if (!std::isfinite(a) || !(a > 0.0) || a > room)
            refuse("--amplitudes-v", "each must be in (0, " + num(room) + "] V: from the base " + num(r.base_V) +
                                         " V the loop must stay within the " + b.whose + " command limits [" +
                                         num(lim.u_min_V) + ", " + num(lim.u_max_V) + "] V (got " + num(a) + ")");
    if (r.cycles < 1 || r.cycles > 100) refuse("--cycles", "must be in [1, 100]");
    // At least 20 ticks a cycle, so the turning points are resolved.
    const double f_max = b.rate_Hz / 20.0;
    if (!std::isfinite(r.frequency_Hz) || !(r.frequency_Hz > 0.0) || r.frequency_Hz > f_max)
        refuse("--frequency-hz", "must be in (0, rate / 20 = " + num(f_max) + "] Hz");
    // The duration first, in double: a frequency near 0 would overflow the
    // tick counts below.
    const double max_s = static_cast<double>(kMaxRecordTicks) / b.rate_Hz;
    const double total_s = static_cast<double>(r.amplitudes_V.size()) * r.cycles / r.frequency_Hz;
    if (!(total_s <= max_s))
        refuse("--frequency-hz", "amplitudes x cycles / frequency must be at most " + num(max_s) + " s (got " +
                                     num(total_s) + " s)");
    LoopsPlan p;
    p.cycle_ticks = static_cast<uint64_t>(std::llround(b.rate_Hz / r.frequency_Hz));
    p.amplitude_ticks = p.cycle_ticks * static_cast<uint64_t>(r.cycles);
    p.ticks = p.amplitude_ticks * r.amplitudes_V.size();
    if (p.ticks > kMaxRecordTicks)
        refuse("--frequency-hz", "amplitudes x cycles / frequency must be at most " + num(max_s) + " s (got " +
                                     num(static_cast<double>(p.ticks) / b.rate_Hz) + " s)");
    return p;
}

ExcitationConfig loop_excitation(const LoopsPlan& p, const LoopsRequest& r, std::size_t j, double rate_Hz) {
    ExcitationConfig c;
    c.signal = r.shape == "sine" ? ExcitationSignal::kRaisedCosine : ExcitationSignal::kTriangle;
    c.point = ExcitationPoint::kCommand;
    c.offset = static_cast<float>(r.base_V);
    c.amplitude = static_cast<float>(r.amplitudes_V.at(j));
    c.sample_rate_Hz = static_cast<float>(rate_Hz);
    c.period_samples = static_cast<uint32_t>(p.cycle_ticks);
    c.periods = static_cast<uint32_t>(r.cycles);
    return c;
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

void analyse_loops_run(const LoopsRequest& r, double rate_Hz, const std::vector<std::vector<double>>& u_V,
                       const std::vector<std::vector<double>>& y_um, LoopsRun& run) {
    const LoopsPlan& plan = run.plan;
    const std::size_t per = static_cast<std::size_t>(plan.amplitude_ticks);
    if (u_V.size() != r.amplitudes_V.size() || y_um.size() != u_V.size())
        throw std::invalid_argument("loops: one recording per amplitude expected");
    for (std::size_t j = 0; j < u_V.size(); ++j) {
        if (u_V[j].size() < per || y_um[j].size() < per)
            throw std::invalid_argument("loops: the recording of an amplitude is shorter than its cycles");
        // The reading at tick k + 1 is the first that the command of tick k
        // moved (the loop's tick of delay): pair them, so that the arrays and
        // the CSV hold (u_k, y_k+1) -- the static map identify pi and dahl fit.
        for (std::size_t k = 0; k + 1 < per; ++k) {
            run.u_V.push_back(u_V[j][k]);
            run.y_um.push_back(y_um[j][k + 1]);
            run.time_s.push_back(static_cast<double>(j * per + k) / rate_Hz);
            run.amplitude_V.push_back(r.amplitudes_V[j]);
        }
        // Its last cycle.
        const auto begin = static_cast<std::ptrdiff_t>(per - plan.cycle_ticks);
        const auto end = static_cast<std::ptrdiff_t>(per - 1);
        const std::vector<double> u(u_V[j].begin() + begin, u_V[j].begin() + end);
        const std::vector<double> y(y_um[j].begin() + begin + 1, y_um[j].begin() + end + 1);
        LoopFigures f;
        f.amplitude_V = r.amplitudes_V[j];
        f.hysteresis_pct = sim::hysteresis_pct(u, y);
        f.max_width_pct = loop_max_width_pct(u, y);
        const auto [ymin, ymax] = std::minmax_element(y.begin(), y.end());
        f.y_min_um = *ymin;
        f.y_max_um = *ymax;
        run.loops.push_back(f);
    }
    if (r.cycles < 2)
        run.warnings.push_back("one cycle per amplitude: the measured cycle includes the transient from the previous "
                               "amplitude; use --cycles >= 2");
    limiter_warnings(run.clipped_samples, run.trip, "the loops are shaped by the limits there", run.warnings);
}

}  // namespace piezoloop::measure
