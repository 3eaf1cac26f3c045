#include "sim/multi_axis_sim_case.hpp"

#include <algorithm>
#include <cmath>
#include <stdexcept>

#include "format/number.hpp"
#include "sim/f32.hpp"

namespace piezoloop::sim {

namespace {

std::string axis_names(const MultiAxisModel& m) {
    std::string list;
    for (const std::string& n : m.names) list += (list.empty() ? "" : ", ") + n;
    return list;
}

int find_axis(const MultiAxisModel& m, const std::string& name, const std::string& option) {
    for (size_t i = 0; i < m.names.size(); ++i)
        if (m.names[i] == name) return static_cast<int>(i);
    throw std::invalid_argument(option + ": must be one of the axes " + axis_names(m) + " (got \"" + name + "\")");
}

double hold_value(const std::string& text, const std::string& option) {
    size_t used = 0;
    double v = 0.0;
    try {
        v = std::stod(text, &used);
    } catch (const std::exception&) {
        used = 0;
    }
    if (used == 0 || used != text.size() || !std::isfinite(v))
        throw std::invalid_argument(option + ": must be a number of um (got \"" + text + "\")");
    return v;
}

}  // namespace

MultiAxisSimPlan plan_multi_axis_sim(const Scenario& s, const MultiAxisSimRequest& r) {
    const SimCaseRequest& a = r.sim;
    if (a.case_name.empty()) throw std::invalid_argument("--case: required (see --list)");
    MultiAxisSimPlan p;
    p.case_spec = s.find_case(a.case_name);
    check_sim_request(a);
    if (a.fidelity != "float")
        throw std::invalid_argument("--fidelity: a stage of coupled axes runs the float stage model only (float)");
    std::string names;
    for (const AxisSpec& x : s.axes) names += (names.empty() ? "" : ", ") + x.name;
    if (r.axis.empty()) throw std::invalid_argument("--axis: a stage of axes " + names + ": choose one");
    CaseSpec& c = p.case_spec;
    if (a.sample == "q31") c.sample = SampleType::kQ31;
    if (a.sample == "float") c.sample = SampleType::kFloat;
    p.trajectory = sim_trajectory(s, a);

    // The axis and the holds are checked before the (slower) build.
    MultiAxisModel names_only;
    for (const AxisSpec& x : s.axes) names_only.names.push_back(x.name);
    const int driven = find_axis(names_only, r.axis, "--axis");

    const RunOptions ro = plan_run(s.rate_Hz, p.trajectory, 0, false);
    MultiAxisRunOptions& o = p.options;
    o.driven = driven;
    o.wave = ro.wave;
    o.wave.sample_rate_Hz = f32(s.rate_Hz);
    const size_t n = s.axes.size();
    // The wave's first value: a triangle at its minimum, a sine at phase 3/4.
    o.hold_um.assign(n, o.wave.offset_um - o.wave.amplitude_um);
    const double fs = s.setup.position.full_scale;
    for (const std::string& h : r.holds) {
        const size_t eq = h.find('=');
        if (eq == std::string::npos) {
            const double v = hold_value(h, "--hold-um");
            if (!(std::fabs(v) <= fs))
                throw std::invalid_argument("--hold-um: must be in [-" + format::significant(fs) + ", " +
                                            format::significant(fs) + "] um, the position full scale (got " + h + ")");
            std::fill(o.hold_um.begin(), o.hold_um.end(), f32(v));
            continue;
        }
        const std::string name = h.substr(0, eq);
        const int i = find_axis(names_only, name, "--hold-um");
        if (i == driven) throw std::invalid_argument("--hold-um " + name + ": the driven axis runs the wave, it holds nothing");
        const double v = hold_value(h.substr(eq + 1), "--hold-um " + name);
        if (!(std::fabs(v) <= fs))
            throw std::invalid_argument("--hold-um " + name + ": must be in [-" + format::significant(fs) + ", " +
                                        format::significant(fs) + "] um, the position full scale (got " + h.substr(eq + 1) + ")");
        o.hold_um[static_cast<size_t>(i)] = f32(v);
    }

    BuildOptions bo;
    bo.reference_frequency_Hz = a.frequency_Hz;
    bo.check_realisation = r.check_realisation;
    p.model = build_multi_axis_case(s, c, bo);

    // Every axis approaches its first value from rest; the driven axis's
    // wave starts when the longest approach ends, so the held axes hold
    // before it moves (or at once, beside them: start_together).
    const uint64_t own = multi_axis_approach_ticks(p.model, o, driven);
    uint64_t lead = own;
    for (size_t i = 0; i < n && !r.start_together; ++i)
        lead = std::max(lead, multi_axis_approach_ticks(p.model, o, static_cast<int>(i)));
    p.approach_ticks = lead;
    p.period_ticks = ro.period_ticks;
    o.wave_tick = lead - own;
    o.ticks = ro.ticks + lead;
    o.window_start = ro.window_start + lead;
    if (a.log) o.log_every = a.log_every > 0 ? static_cast<uint64_t>(a.log_every) : std::max<uint64_t>(1, o.ticks / 200000);
    return p;
}

nlohmann::json multi_axis_sim_summary(const Scenario& s, const MultiAxisSimRequest& r, const MultiAxisSimPlan& p,
                                      const MultiAxisRunResult& res) {
    const SimCaseRequest& a = r.sim;
    const MultiAxisRunOptions& o = p.options;
    const MultiAxisModel& m = p.model;
    const int d = o.driven;
    const double range = res.axes[static_cast<size_t>(d)].tracking.range_um;
    nlohmann::json out;
    out["scenario"] = s.name;
    out["case"] = p.case_spec.name;
    out["label"] = p.case_spec.label;
    out["fidelity"] = "float";
    out["sample"] = to_string(m.sample);
    out["loop_rate_Hz"] = s.rate_Hz;
    out["axis"] = m.names[static_cast<size_t>(d)];
    out["trajectory"] = {{"waveform", a.trajectory},
                         {"frequency_Hz", a.frequency_Hz},
                         {"range_um", p.trajectory.range_um},
                         {"offset_um", o.wave.offset_um},
                         {"periods", static_cast<double>(o.ticks - p.approach_ticks) / static_cast<double>(p.period_ticks)}};
    if (a.amplitude_V > 0.0) out["trajectory"]["range_piezo_V"] = a.amplitude_V;
    out["ticks"] = res.ticks;
    out["window_start_tick"] = o.window_start;
    out["window_ticks"] = res.ticks - o.window_start;
    out["approach_ticks"] = p.approach_ticks;
    // The driven axis's tracking, as a single-axis run reports it.
    const TrackingMetrics& t = res.axes[static_cast<size_t>(d)].tracking;
    out["e_max_pct"] = t.e_max_pct;
    out["e_rms_pct"] = t.e_rms_pct;
    out["e_max_um"] = t.e_max_um;
    out["e_rms_um"] = t.e_rms_um;
    out["e_pp_um"] = t.e_pp_um;
    nlohmann::json axes = nlohmann::json::object(), cross = nlohmann::json::object();
    for (size_t i = 0; i < m.names.size(); ++i) {
        const AxisRunResult& ar = res.axes[i];
        const bool driven = static_cast<int>(i) == d;
        nlohmann::json j;
        j["role"] = driven ? "wave" : "hold";
        if (!driven) j["hold_um"] = o.hold_um[i];
        j["e_max_um"] = ar.tracking.e_max_um;
        j["e_rms_um"] = ar.tracking.e_rms_um;
        // Of the driven axis's range for every axis (a held axis has none).
        j["e_max_pct"] = range > 0.0 ? 100.0 * ar.tracking.e_max_um / range : 0.0;
        j["e_rms_pct"] = range > 0.0 ? 100.0 * ar.tracking.e_rms_um / range : 0.0;
        j["position_pp_um"] = ar.position_max_um - ar.position_min_um;
        j["limiter"] = {{"trip", trip_reason_name(ar.trip)}, {"clamped_samples", ar.clamped_samples}};
        j["channel_clamped_samples"] = ar.channel_clamped_samples;
        if (!driven) {
            j["cross_motion_pct"] = cross_motion_pct(res, d, static_cast<int>(i));
            cross[m.names[i]] = j["cross_motion_pct"];
        }
        axes[m.names[i]] = j;
    }
    out["axes"] = axes;
    out["cross_motion_pct"] = cross;
    const double simulated = static_cast<double>(res.ticks) / s.rate_Hz;
    out["realtime_factor"] = res.wall_s > 0.0 ? simulated / res.wall_s : 0.0;
    out["wall_s"] = res.wall_s;
    out["log_hash"] = format::hex64(res.log_hash);
    out["output_matrix"] = m.output_matrix.empty() ? nlohmann::json("identity") : nlohmann::json(m.output_matrix);
    for (size_t i = 0; i < m.axes.size(); ++i)
        for (const std::string& n : m.axes[i].notes) out["notes"].push_back(m.names[i] + ": " + n);
    return out;
}

}  // namespace piezoloop::sim
