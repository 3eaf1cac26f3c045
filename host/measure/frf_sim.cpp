#include "measure/frf_sim.hpp"

#include <chrono>
#include <cmath>
#include <memory>
#include <stdexcept>

#include "format/number.hpp"
#include "piezoloop/excitation.hpp"
#include "piezoloop/pipeline.hpp"
#include "piezoloop/reference_run.hpp"
#include "sim/build_case.hpp"
#include "sim/loop_kernel.hpp"
#include "status_text.hpp"

namespace piezoloop::measure {

namespace {

std::string num(double x) { return format::significant(x, 6); }

[[noreturn]] void refuse(const std::string& option, const std::string& why) {
    throw std::invalid_argument(option + ": " + why);
}

template <class T>
FrfRun run_with(const sim::LoopModel& m, const FrfRequest& r, const FrfPlan& plan, double setpoint_um,
                const std::function<void(double)>& progress) {
    using PipelineT = Pipeline<T, sim::kSimRcCapacity, 4, 1024, kSimExcitationCapacity>;
    auto pipe = std::make_unique<PipelineT>(m.setup);
    auto fail = [](const char* what, const Status& st) {
        throw std::invalid_argument(std::string(what) + ": " + describe(st));
    };
    if (const Status st = pipe->stage(m.params); !st.ok()) fail("controller", st);
    if (r.closed) (void)pipe->set_setpoint(m.setup.position.to_sample<T>(static_cast<float>(setpoint_um)));
    ExcitationConfig c;
    c.signal = plan.signal == "sweep"  ? ExcitationSignal::kSweep
               : plan.signal == "prbs" ? ExcitationSignal::kPrbs
                                       : ExcitationSignal::kMultisine;
    c.point = ExcitationPoint::kCommand;
    c.amplitude = static_cast<float>(r.amplitude_V);
    c.offset = r.closed ? 0.0f : static_cast<float>(r.bias_V);
    c.sample_rate_Hz = m.setup.rate_Hz;
    c.period_samples = plan.period_samples;
    c.first_bin = plan.layout.first_bin;
    c.last_bin = plan.layout.last_bin;
    c.f1_Hz = static_cast<float>(r.from_Hz);
    c.f2_Hz = static_cast<float>(r.to_Hz);
    c.prbs_order = plan.prbs_order;
    c.prbs_hold = plan.prbs_hold;
    c.periods = static_cast<uint32_t>(r.transient_periods + r.periods);
    if (const Status st = pipe->start_excitation(c); !st.ok()) fail("excitation", st);
    pipe->arm();

    StageModel stage;
    StageConfig sc = m.stage;
    sc.rate_Hz = m.setup.rate_Hz;
    if (const Status st = stage.configure(sc); !st.ok()) fail("plant", st);

    FrfRun run;
    run.plan = plan;
    const std::size_t n_meas = static_cast<std::size_t>(plan.ticks - plan.measured_start);
    std::vector<double> u, y;
    u.reserve(n_meas);
    y.reserve(n_meas);
    uint32_t clip_at_start = 0;
    auto clip_count = [&] { return pipe->limiter().clamped_samples() + pipe->limiter().slew_limited_samples(); };
    const uint64_t progress_every = uint64_t{1} << 15;
    auto observe = [&](const sim::TickView& v, const TickSignals<T>&, const StageModel&) {
        if (v.k >= plan.measured_start) {
            u.push_back(static_cast<double>(v.u_V));
            y.push_back(static_cast<double>(v.y_um));
        }
        if (v.k + 1 == plan.measured_start) clip_at_start = clip_count();
        if (progress && (v.k + 1) % progress_every == 0)
            progress(static_cast<double>(v.k + 1) / static_cast<double>(plan.ticks));
    };
    reference::LogHash hash;
    const auto t0 = std::chrono::steady_clock::now();
    sim::run_ticks<T>(*pipe, stage, m.stage.sensor.gain, plan.ticks, &hash, observe);
    run.wall_s = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
    if (progress) progress(1.0);
    run.log_hash = hash.value();
    const uint32_t clip_end = clip_count();
    run.clipped_transient = plan.measured_start == 0 ? 0 : clip_at_start;
    run.clipped_samples = clip_end - clip_at_start;
    run.trip = trip_reason_name(pipe->limiter().trip_reason());
    if (plan.signal == "multisine") {
        run.estimate = estimate_multisine(u, y, plan.layout);
    } else {
        WelchEstimate w = estimate_h1(u, y, plan.layout.rate_Hz, plan.segment_samples, r.from_Hz, r.to_Hz);
        run.coherence = w.coherence;
        run.segments = w.segments;
        run.estimate = static_cast<const FrfEstimate&>(w);
    }
    return run;
}

}  // namespace

FrfPlan plan_frf(const sim::Scenario& s, const FrfRequest& r) {
    const double rate = s.rate_Hz, nyq = 0.5 * rate;
    if (!std::isfinite(r.from_Hz) || !(r.from_Hz > 0.0)) refuse("--from-hz", "must be > 0 Hz");
    if (!std::isfinite(r.to_Hz) || !(r.to_Hz < nyq))
        refuse("--to-hz", "must be below the Nyquist frequency, rate / 2 = " + num(nyq) + " Hz");
    if (!(r.from_Hz < r.to_Hz)) refuse("--from-hz", "must be below --to-hz (" + num(r.to_Hz) + " Hz)");
    const double lowest = rate / kSimExcitationCapacity;
    if (r.from_Hz < lowest)
        refuse("--from-hz", "must be >= rate / " + std::to_string(kSimExcitationCapacity) + " = " + num(lowest) +
                                " Hz (one period of the multisine is tabulated)");
    if (r.periods < 1 || r.periods > 10000) refuse("--periods", "must be in [1, 10000]");
    if (r.transient_periods < 0 || r.transient_periods > 100) refuse("--transient-periods", "must be in [0, 100]");
    const LimitsConfig& lim = s.limits;
    if (!std::isfinite(r.amplitude_V) || !(r.amplitude_V > 0.0))
        refuse("--amplitude-v", "must be > 0 V");
    if (!std::isfinite(r.bias_V)) refuse("--bias-v", "must be finite");
    if (!r.closed) {
        if (r.bias_V < lim.u_min_V || r.bias_V > lim.u_max_V)
            refuse("--bias-v", "must be within the scenario's limits [" + num(lim.u_min_V) + ", " +
                                   num(lim.u_max_V) + "] V");
        const double room = std::min(lim.u_max_V - r.bias_V, r.bias_V - lim.u_min_V);
        if (r.amplitude_V > room)
            refuse("--amplitude-v", "bias " + num(r.bias_V) + " V +- amplitude must stay within the scenario's limits [" +
                                        num(lim.u_min_V) + ", " + num(lim.u_max_V) + "] V: at most " + num(room) +
                                        " V at this bias");
    } else if (r.amplitude_V > 0.5 * (lim.u_max_V - lim.u_min_V)) {
        refuse("--amplitude-v", "must be at most half the scenario's range [" + num(lim.u_min_V) + ", " +
                                    num(lim.u_max_V) + "] V");
    }
    FrfPlan p;
    p.signal = r.signal;
    p.layout.rate_Hz = rate;
    if (r.signal == "sweep" || r.signal == "prbs") {
        uint32_t seg = 8;
        while (seg < rate / r.from_Hz - 1e-9) seg *= 2;
        if (r.to_Hz < rate / seg)
            refuse("--to-hz", "no FFT bin between --from-hz and --to-hz at a resolution of " + num(rate / seg) + " Hz");
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
        return p;
    }
    if (r.signal != "multisine") refuse("--signal", "must be multisine, sweep or prbs");
    const uint32_t N = static_cast<uint32_t>(std::floor(rate / r.from_Hz + 1e-9));
    p.period_samples = N;
    p.layout.period_samples = N;
    p.layout.first_bin = std::max<uint32_t>(1, static_cast<uint32_t>(std::ceil(r.from_Hz * N / rate - 1e-9)));
    p.layout.last_bin = static_cast<uint32_t>(std::floor(r.to_Hz * N / rate + 1e-9));
    if (2 * p.layout.last_bin >= N) p.layout.last_bin = (N - 1) / 2;
    if (p.layout.last_bin < p.layout.first_bin)
        refuse("--to-hz", "no DFT line between --from-hz and --to-hz at a spacing of " + num(rate / N) + " Hz");
    p.measured_start = uint64_t{N} * static_cast<uint64_t>(r.transient_periods);
    p.ticks = uint64_t{N} * static_cast<uint64_t>(r.transient_periods + r.periods);
    return p;
}

FrfRun run_frf_sim(const sim::Scenario& s, const sim::CaseSpec* case_spec, const FrfRequest& r,
                   const std::function<void(double)>& progress) {
    const FrfPlan plan = plan_frf(s, r);
    sim::LoopModel m;
    if (r.closed) {
        if (!case_spec) refuse("--case", "closed loop needs the case whose controller closes it");
        sim::BuildOptions bo;
        bo.check_realisation = false;
        m = sim::build_case(s, *case_spec, bo).model;
    } else {
        sim::build_stage(s, case_spec, 10, m);
        m.setup = s.setup;
        m.params = PipelineParams{};
        m.params.limits = s.limits;
        m.sample = case_spec ? case_spec->sample : sim::SampleType::kFloat;
    }
    // Closed loop holds the displacement the bias gives at the mean slope.
    const double setpoint_um = r.bias_V * s.command_um_per_V();
    FrfRun run = m.sample == sim::SampleType::kQ31 ? run_with<Q31>(m, r, plan, setpoint_um, progress)
                                                   : run_with<float>(m, r, plan, setpoint_um, progress);
    if (run.clipped_samples > 0)
        run.warnings.push_back("the limiter clamped or slew-limited " + std::to_string(run.clipped_samples) +
                               " samples of the measured periods: the response is not that of the linear stage there");
    if (run.trip != "none") run.warnings.push_back("the limiter tripped (" + run.trip + "): the output went to safe");
    if (r.periods < 2 && r.signal == "multisine")
        run.warnings.push_back("one measured period: no noise variance (std_db is null); use --periods >= 2");
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
                               " lines have a standard deviation above 1 dB (first at " + num(f_low_first) +
                               " Hz): raise --amplitude-v or --periods");
    return run;
}

}  // namespace piezoloop::measure
