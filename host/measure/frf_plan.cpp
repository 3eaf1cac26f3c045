#include "measure/frf_plan.hpp"

#include <algorithm>
#include <cmath>
#include <stdexcept>

#include "format/number.hpp"
#include "measure/record_bound.hpp"
#include "options/option_checks.hpp"

namespace piezoloop::measure {

namespace {


using options::refuse;

// The measured part of a recording, in its own estimate: the periodic one
// for a multisine, H1 for a sweep or a PRBS.
WelchEstimate estimate(const FrfRequest& r, const FrfPlan& plan, const std::vector<double>& in,
                       const std::vector<double>& out) {
    if (plan.signal == "multisine") {
        WelchEstimate w;
        static_cast<FrfEstimate&>(w) = estimate_multisine(in, out, plan.layout);
        return w;
    }
    return estimate_h1(in, out, plan.layout.rate_Hz, plan.segment_samples, r.from_Hz, r.to_Hz);
}

// Sweep, PRBS: the longest Welch segment, samples (2^20: a resolution of
// rate / 2^20, 0.01 Hz at 10 kHz, and at most 2^19 lines).
constexpr uint32_t kMaxSegmentSamples = 1u << 20;

// The whole run (transient and measured periods) within the longest record.
void check_record(double rate, const FrfPlan& p) {
    if (p.ticks <= kMaxRecordTicks) return;
    refuse("--periods", "(--transient-periods + --periods) x " + std::to_string(p.period_samples) +
                            " ticks a period = " + std::to_string(p.ticks) + " ticks (" +
                            format::significant(static_cast<double>(p.ticks) / rate) + " s) exceeds the longest record, " +
                            std::to_string(kMaxRecordTicks) + " ticks (" +
                            format::significant(static_cast<double>(kMaxRecordTicks) / rate) +
                            " s at this rate): lower --periods or raise --from-hz");
}

}  // namespace

MultisineLayout multisine_lines(double rate, double from_Hz, double to_Hz) {
    MultisineLayout l;
    l.rate_Hz = rate;
    const uint32_t N = static_cast<uint32_t>(std::floor(rate / from_Hz + 1e-9));
    l.period_samples = N;
    l.first_bin = std::max<uint32_t>(1, static_cast<uint32_t>(std::ceil(from_Hz * N / rate - 1e-9)));
    l.last_bin = static_cast<uint32_t>(std::floor(to_Hz * N / rate + 1e-9));
    if (2 * l.last_bin >= N) l.last_bin = (N - 1) / 2;
    if (l.last_bin < l.first_bin)
        refuse("--to-hz", "no DFT line between --from-hz and --to-hz at a spacing of " + format::significant(rate / N) + " Hz");
    return l;
}

FrfPlan plan_frf(double rate, const LimitsConfig& lim, uint32_t capacity, const FrfRequest& r,
                 const std::string& whose) {
    const double nyq = 0.5 * rate;
    if (!std::isfinite(r.from_Hz) || !(r.from_Hz > 0.0)) refuse("--from-hz", "must be > 0 Hz");
    if (!std::isfinite(r.to_Hz) || !(r.to_Hz < nyq))
        refuse("--to-hz", "must be below the Nyquist frequency, rate / 2 = " + format::significant(nyq) + " Hz");
    if (!(r.from_Hz < r.to_Hz)) refuse("--from-hz", "must be below --to-hz (" + format::significant(r.to_Hz) + " Hz)");
    const double lowest = rate / capacity;
    if (r.signal == "multisine" && r.from_Hz < lowest)
        refuse("--from-hz", "must be >= rate / " + std::to_string(capacity) + " = " + format::significant(lowest) +
                                " Hz (one period of the multisine is tabulated; a sweep or a PRBS goes lower)");
    if (r.periods < 1 || r.periods > 10000) refuse("--periods", "must be in [1, 10000]");
    if (r.transient_periods < 0 || r.transient_periods > 100) refuse("--transient-periods", "must be in [0, 100]");
    if (!std::isfinite(r.amplitude_V) || !(r.amplitude_V > 0.0))
        refuse("--amplitude-v", "must be > 0 V");
    if (!std::isfinite(r.bias_V)) refuse("--bias-v", "must be finite");
    if (!r.closed) {
        if (r.bias_V < lim.u_min_V || r.bias_V > lim.u_max_V)
            refuse("--bias-v", "must be within the " + whose + " limits [" + format::significant(lim.u_min_V) + ", " +
                                   format::significant(lim.u_max_V) + "] V");
        const double room = std::min(lim.u_max_V - r.bias_V, r.bias_V - lim.u_min_V);
        if (r.amplitude_V > room)
            refuse("--amplitude-v", "bias " + format::significant(r.bias_V) + " V +- amplitude must stay within the " + whose + " limits [" +
                                        format::significant(lim.u_min_V) + ", " + format::significant(lim.u_max_V) + "] V: at most " + format::significant(room) +
                                        " V at this bias");
    } else if (r.amplitude_V > 0.5 * (lim.u_max_V - lim.u_min_V)) {
        refuse("--amplitude-v", "must be at most half the " + whose + " range [" + format::significant(lim.u_min_V) + ", " +
                                    format::significant(lim.u_max_V) + "] V");
    }
    FrfPlan p;
    p.signal = r.signal;
    p.layout.rate_Hz = rate;
    if (r.signal == "sweep" || r.signal == "prbs") {
        // The Welch segment, and with it the lines, is bounded before it is
        // counted out.
        if (!(rate / r.from_Hz <= kMaxSegmentSamples))
            refuse("--from-hz", "must be >= rate / " + std::to_string(kMaxSegmentSamples) + " = " +
                                    format::significant(rate / kMaxSegmentSamples) + " Hz for a sweep or a PRBS (its Welch segment)");
        uint32_t seg = 8;
        while (seg < rate / r.from_Hz - 1e-9) seg *= 2;
        if (r.to_Hz < rate / seg)
            refuse("--to-hz", "no FFT bin between --from-hz and --to-hz at a resolution of " + format::significant(rate / seg) + " Hz");
        p.segment_samples = seg;
        if (r.signal == "sweep") {
            p.period_samples = 4 * seg;
        } else {
            p.prbs_hold = std::max<uint32_t>(1, static_cast<uint32_t>(std::floor(0.4 * rate / r.to_Hz)));
            uint32_t order = 2;
            while (((uint64_t{1} << order) - 1) * p.prbs_hold < seg) ++order;
            if (order > 24) refuse("--from-hz", "too low for a PRBS of order <= 24 at this rate and --to-hz");
            p.prbs_order = order;
            p.period_samples = static_cast<uint32_t>(((uint64_t{1} << order) - 1) * p.prbs_hold);
        }
        p.measured_start = uint64_t{p.period_samples} * static_cast<uint64_t>(r.transient_periods);
        p.ticks = uint64_t{p.period_samples} * static_cast<uint64_t>(r.transient_periods + r.periods);
        check_record(rate, p);
        return p;
    }
    if (r.signal != "multisine") refuse("--signal", "must be multisine, sweep or prbs");
    p.layout = multisine_lines(rate, r.from_Hz, r.to_Hz);
    const uint32_t N = p.layout.period_samples;
    p.period_samples = N;
    p.measured_start = uint64_t{N} * static_cast<uint64_t>(r.transient_periods);
    p.ticks = uint64_t{N} * static_cast<uint64_t>(r.transient_periods + r.periods);
    check_record(rate, p);
    return p;
}

ExcitationConfig excitation_config(const FrfPlan& plan, const FrfRequest& r) {
    ExcitationConfig c;
    c.signal = plan.signal == "sweep"  ? ExcitationSignal::kSweep
               : plan.signal == "prbs" ? ExcitationSignal::kPrbs
                                       : ExcitationSignal::kMultisine;
    c.point = ExcitationPoint::kCommand;
    c.amplitude = static_cast<float>(r.amplitude_V);
    c.offset = r.closed ? 0.0f : static_cast<float>(r.bias_V);
    c.sample_rate_Hz = static_cast<float>(plan.layout.rate_Hz);
    c.period_samples = plan.period_samples;
    c.first_bin = plan.layout.first_bin;
    c.last_bin = plan.layout.last_bin;
    c.f1_Hz = static_cast<float>(r.from_Hz);
    c.f2_Hz = static_cast<float>(r.to_Hz);
    c.prbs_order = plan.prbs_order;
    c.prbs_hold = plan.prbs_hold;
    c.periods = static_cast<uint32_t>(r.transient_periods + r.periods);
    return c;
}

void analyse_frf(const FrfRequest& r, const std::vector<double>& u, const std::vector<double>& y,
                 const std::vector<double>& d, FrfRun& run) {
    const WelchEstimate g = estimate(r, run.plan, u, y);
    if (!y.empty()) {
        const auto [lo, hi] = std::minmax_element(y.begin(), y.end());
        run.y_min_um = *lo;
        run.y_max_um = *hi;
        run.y_at_min = static_cast<std::size_t>(std::count(y.begin(), y.end(), *lo));
        run.y_at_max = static_cast<std::size_t>(std::count(y.begin(), y.end(), *hi));
    }
    run.coherence = g.coherence;
    run.segments = g.segments;
    run.estimate = static_cast<const FrfEstimate&>(g);
    if (r.closed) {
        // d -> u is the input sensitivity (u = -K G u + d), and the plant
        // G = (Y / D) / (U / D) is the ratio estimated above.
        const WelchEstimate s = estimate(r, run.plan, d, u);
        run.sensitivity = s.response;
        run.complementary_sensitivity.clear();
        for (const cplx& x : s.response) run.complementary_sensitivity.push_back(1.0 - x);
    }
    if (run.clipped_samples > 0)
        run.warnings.push_back("the limiter clamped or slew-limited " + std::to_string(run.clipped_samples) +
                               " samples of the measured periods: the response is not that of the linear stage there");
    if (run.trip != "none") run.warnings.push_back("the limiter tripped (" + run.trip + "): the output went to safe");
    if (r.periods < 2 && r.signal == "multisine")
        run.warnings.push_back("one measured period: no noise variance (std_db is null); use --periods >= 2");
    if (!run.estimate.transient_lines.empty()) {
        const FrfEstimate& e = run.estimate;
        std::size_t worst = e.transient_lines.front();
        for (const std::size_t i : e.transient_lines)
            if (e.half_change_rel[i] > e.half_change_rel[worst]) worst = i;
        run.warnings.push_back(
            std::to_string(e.transient_lines.size()) + " of " + std::to_string(e.frequency_Hz.size()) +
            " lines differ between the first and the second half of the measured periods beyond their noise (" +
            format::significant(e.frequency_Hz[e.transient_lines.front()]) + " to " +
            format::significant(e.frequency_Hz[e.transient_lines.back()]) + " Hz; the largest, " +
            format::significant(100.0 * e.half_change_rel[worst], 2) + " % at " + format::significant(e.frequency_Hz[worst]) +
            " Hz): the stage had not settled (a lightly damped mode ringing from the start, its hysteresis or creep "
            "still moving); raise --transient-periods");
    }
    int incoherent = 0;
    for (const double c : run.coherence) incoherent += c < 0.95 ? 1 : 0;
    if (incoherent > 0)
        run.warnings.push_back(std::to_string(incoherent) + " of " + std::to_string(run.coherence.size()) +
                               " lines have a coherence below 0.95");
    int low = 0;
    double f_low_first = 0.0;
    for (std::size_t i = 0; i < run.estimate.std_db.size(); ++i) {
        if (run.estimate.std_db[i] > 1.0) {
            if (low++ == 0) f_low_first = run.estimate.frequency_Hz[i];
        }
    }
    if (low > 0)
        run.warnings.push_back(std::to_string(low) + " of " + std::to_string(run.estimate.std_db.size()) +
                               " lines have a standard deviation above 1 dB (first at " + format::significant(f_low_first) +
                               " Hz): raise --amplitude-v or --periods");
}

}  // namespace piezoloop::measure
