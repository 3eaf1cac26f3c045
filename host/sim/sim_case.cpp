// The planning and summary halves of `piezoloop sim` (sim_case.hpp), moved
// out of the command so the Python module runs exactly the same case.
#include "sim/sim_case.hpp"

#include <algorithm>
#include <cmath>
#include <stdexcept>

#include "format/number.hpp"
#include "options/option_checks.hpp"

namespace piezoloop::sim {

void check_sim_request(const SimCaseRequest& a) {
    if (a.trajectory != "triangle" && a.trajectory != "sine")
        throw std::invalid_argument("--trajectory: must be triangle or sine (got " + a.trajectory + ")");
    if (a.fidelity != "float" && a.fidelity != "double")
        throw std::invalid_argument("--fidelity: must be float or double (got " + a.fidelity + ")");
    if (!a.sample.empty() && a.sample != "float" && a.sample != "q31")
        throw std::invalid_argument("--sample: must be float or q31 (got " + a.sample + ")");
    if (!a.offset.empty() && a.offset != "unipolar" && a.offset != "bipolar")
        throw std::invalid_argument("--offset: must be unipolar or bipolar (got " + a.offset + ")");
    options::require_in("--frequency-hz", a.frequency_Hz, 1e-4, 5e5, "Hz");
    if (a.amplitude_um != 0.0) options::require_in("--amplitude-um", a.amplitude_um, 1e-6, 1e3, "um");
    if (a.amplitude_V != 0.0) options::require_in("--amplitude-v", a.amplitude_V, 1e-6, 1e4, "V");
    if ((a.amplitude_um > 0.0) == (a.amplitude_V > 0.0))
        throw std::invalid_argument("give exactly one of --amplitude-um and --amplitude-v");
    if (a.midpoint_um) options::require_in("--midpoint-um", *a.midpoint_um, -1e3, 1e3, "um");
    if (a.duration_s != 0.0) options::require_in("--duration-s", a.duration_s, 1e-6, 1e4, "s");
    options::require_in("--substeps", a.substeps, 1, 10000);
    // 0: the default (at most 200000 rows).
    if (a.log_every != 0) options::require_in("--log-every", a.log_every, 1, 1 << 30);
}

TrajectoryRequest sim_trajectory(const Scenario& s, const SimCaseRequest& a) {
    TrajectoryRequest t;
    t.waveform = a.trajectory == "sine" ? Waveform::kSine : Waveform::kTriangle;
    t.frequency_Hz = a.frequency_Hz;
    t.range_um = a.amplitude_um > 0.0 ? a.amplitude_um : a.amplitude_V * s.nominal_um_per_V;
    t.unipolar = (a.offset.empty() ? s.offset : a.offset) == "unipolar";
    t.midpoint_um = a.midpoint_um;
    const double period_s = 1.0 / a.frequency_Hz;
    const double duration = a.duration_s > 0.0 ? a.duration_s : 2.0 * period_s;
    if (duration < period_s * (1.0 - 1e-9))
        throw std::invalid_argument("--duration-s: must cover at least one period (" + std::to_string(period_s) + " s)");
    t.periods = std::max(1, static_cast<int>(std::floor(duration / period_s + 1e-9)));
    return t;
}

SimCasePlan plan_sim_case(const Scenario& s, const SimCaseRequest& a) {
    if (a.case_name.empty()) throw std::invalid_argument("--case: required (see --list)");
    SimCasePlan p;
    p.case_spec = s.find_case(a.case_name);
    check_sim_request(a);
    CaseSpec& c = p.case_spec;
    if (a.sample == "q31") c.sample = SampleType::kQ31;
    if (a.sample == "float") c.sample = SampleType::kFloat;

    TrajectoryRequest& t = p.trajectory;
    t = sim_trajectory(s, a);

    BuildOptions bo;
    bo.reference_frequency_Hz = a.frequency_Hz;
    bo.substeps = a.substeps;
    p.built = build_case(s, c, bo);

    RunOptions& o = p.options;
    o = plan_run(s.rate_Hz, t, 0, false);
    if (a.log) {
        o.log_start = 0;
        o.log_every = a.log_every > 0 ? static_cast<uint64_t>(a.log_every) : std::max<uint64_t>(1, o.ticks / 200000);
    }
    o.fidelity = a.fidelity == "double" ? Fidelity::kDouble : Fidelity::kFloat;
    // The wave's approach goes in front of --duration-s, as a board's
    // record of the same length does (board = simulator).
    make_room_for_approach(p.built.model, o);
    return p;
}

nlohmann::json sim_case_summary(const Scenario& s, const SimCaseRequest& a, const SimCasePlan& p,
                                const RunResult& r) {
    const CaseSpec& c = p.case_spec;
    const RunOptions& o = p.options;
    nlohmann::json out;
    out["scenario"] = s.name;
    out["case"] = c.name;
    out["label"] = c.label;
    out["fidelity"] = to_string(o.fidelity);
    if (o.fidelity == Fidelity::kDouble) out["substeps"] = a.substeps;
    out["sample"] = to_string(c.sample);
    out["loop_rate_Hz"] = s.rate_Hz;
    out["trajectory"] = {{"waveform", a.trajectory},
                         {"frequency_Hz", a.frequency_Hz},
                         {"range_um", p.trajectory.range_um},
                         {"offset_um", o.wave.offset_um},
                         {"periods", static_cast<double>(o.ticks) / static_cast<double>(o.period_ticks)}};
    if (a.amplitude_V > 0.0) out["trajectory"]["range_piezo_V"] = a.amplitude_V;
    out["ticks"] = r.ticks;
    out["window_ticks"] = r.ticks - o.window_start;
    out["approach_ticks"] = o.approach_ticks;
    out["hysteresis_pct"] = r.hysteresis_pct >= 0.0 ? nlohmann::json(r.hysteresis_pct) : nlohmann::json();
    out["e_max_pct"] = r.tracking.e_max_pct;
    out["e_rms_pct"] = r.tracking.e_rms_pct;
    out["e_max_um"] = r.tracking.e_max_um;
    out["e_rms_um"] = r.tracking.e_rms_um;
    out["e_pp_um"] = r.tracking.e_pp_um;
    out["realtime_factor"] = r.realtime_factor;
    out["wall_s"] = r.wall_s;
    out["log_hash"] = format::hex64(r.log_hash);
    out["limiter"] = {{"trip", trip_reason_name(r.trip)}, {"clamped_samples", r.clamped_samples}};
    for (const std::string& n : p.built.notes) out["notes"].push_back(n);
    if (p.built.dahl) {
        const DahlParams& d = p.built.dahl->params;
        out["dahl_identified"] = {{"alpha1", d.alpha1}, {"alpha2", d.alpha2}, {"beta1", d.beta1},
                                  {"beta2", d.beta2},   {"gamma_a", d.gamma_a}, {"ga", d.ga},
                                  {"nrmse_percent", p.built.dahl->fit.nrmse_percent}};
    }
    return out;
}

}  // namespace piezoloop::sim
