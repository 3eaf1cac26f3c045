// piezoloop.sim: one scenario case run by sim::plan_sim_case and
// sim::run_loop, exactly as `piezoloop sim` runs it (sim/sim_case.hpp), so
// the log hash is the one `piezoloop sim --hash` prints. A stage of coupled
// axes runs through sim::plan_multi_axis_sim and sim::run_multi_axis
// (sim/multi_axis_sim_case.hpp), as `piezoloop sim --axis` runs it.
#include <pybind11/numpy.h>
#include <pybind11/stl.h>

#include <optional>
#include <stdexcept>
#include <string>
#include <vector>

#include "bindings.hpp"
#include "sim/closed_loop.hpp"
#include "sim/multi_axis_sim_case.hpp"
#include "sim/scenario.hpp"
#include "sim/sim_case.hpp"

namespace piezoloop::py {
namespace {

template <class T>
pyb::array_t<double> column(const std::vector<T>& v) {
    pyb::array_t<double> a(static_cast<pyb::ssize_t>(v.size()));
    auto w = a.mutable_unchecked<1>();
    for (std::size_t i = 0; i < v.size(); ++i) w(static_cast<pyb::ssize_t>(i)) = static_cast<double>(v[i]);
    return a;
}

// A stage of coupled axes: per logged tick the columns of the CLI's --out
// (r_<axis>_um, y_<axis>_um, u_<axis>_V, p_<axis>_um) and the JSON
// `piezoloop sim` prints.
pyb::dict run_multi_axis_sim(const sim::Scenario& s, const sim::MultiAxisSimRequest& req) {
    sim::MultiAxisSimPlan plan;
    sim::MultiAxisRunResult r;
    {
        pyb::gil_scoped_release release;
        plan = sim::plan_multi_axis_sim(s, req);
        r = sim::run_multi_axis(plan.model, plan.options);
    }
    const sim::MultiAxisLog& l = r.log;
    std::vector<double> t_s(l.tick.size());
    for (std::size_t i = 0; i < l.tick.size(); ++i) t_s[i] = static_cast<double>(l.tick[i]) / s.rate_Hz;
    pyb::dict signals;
    signals["tick"] = column(l.tick);
    signals["t_s"] = column(t_s);
    const std::vector<std::string>& names = plan.model.names;
    for (std::size_t i = 0; i < names.size(); ++i) {
        signals[pyb::str("r_" + names[i] + "_um")] = column(l.r_um[i]);
        signals[pyb::str("y_" + names[i] + "_um")] = column(l.y_um[i]);
        signals[pyb::str("u_" + names[i] + "_V")] = column(l.u_V[i]);
        signals[pyb::str("p_" + names[i] + "_um")] = column(l.p_um[i]);
    }
    pyb::dict out;
    out["signals"] = signals;
    out["metrics"] = to_python(sim::multi_axis_sim_summary(s, req, plan, r));
    return out;
}

pyb::dict run_sim(const std::string& scenario, const sim::SimCaseRequest& req, const std::string& axis,
                  const std::vector<std::string>& holds) {
    sim::Scenario s;
    {
        pyb::gil_scoped_release release;
        s = sim::load_scenario(scenario);
    }
    if (s.multi_axis()) {
        sim::MultiAxisSimRequest m;
        m.sim = req;
        m.axis = axis;
        m.holds = holds;
        return run_multi_axis_sim(s, m);
    }
    if (!axis.empty()) throw std::invalid_argument("axis: the scenario's stage has one axis (leave axis out)");
    if (!holds.empty()) throw std::invalid_argument("hold_um: the scenario's stage has one axis (leave hold_um out)");
    sim::SimCasePlan plan;
    sim::RunResult r;
    {
        // The run takes seconds; other Python threads go on meanwhile.
        pyb::gil_scoped_release release;
        plan = sim::plan_sim_case(s, req);
        r = sim::run_loop(plan.built.model, plan.options);
    }
    const sim::RunLog& l = r.log;
    std::vector<double> t_s(l.tick.size());
    // e as the CLI's CSV has it: r - y in float, the samples' own type.
    std::vector<float> e_um(l.tick.size());
    for (std::size_t i = 0; i < l.tick.size(); ++i) {
        t_s[i] = static_cast<double>(l.tick[i]) / s.rate_Hz;
        e_um[i] = l.r_um[i] - l.y_um[i];
    }
    pyb::dict signals;
    signals["tick"] = column(l.tick);
    signals["t_s"] = column(t_s);
    signals["r_um"] = column(l.r_um);
    signals["y_um"] = column(l.y_um);
    signals["e_um"] = column(e_um);
    signals["u_V"] = column(l.u_V);
    signals["u_ff_V"] = column(l.u_ff_V);
    signals["u_fb_V"] = column(l.u_fb_V);
    signals["v_piezo_V"] = column(l.v_piezo_V);
    signals["x_um"] = column(l.x_um);
    pyb::dict out;
    out["signals"] = signals;
    out["metrics"] = to_python(sim::sim_case_summary(s, req, plan, r));
    return out;
}

}  // namespace

void add_sim(pyb::module_& m) {
    m.def(
        "sim",
        [](const std::string& scenario, const std::string& case_name, const std::string& trajectory,
           double frequency_Hz, double amplitude_um, double amplitude_V, const std::string& offset,
           std::optional<double> midpoint_um, double duration_s, const std::string& sample,
           const std::string& fidelity, int substeps, bool log, int log_every, const std::string& axis,
           const std::vector<std::string>& holds) {
            sim::SimCaseRequest r;
            r.case_name = case_name;
            r.trajectory = trajectory;
            r.frequency_Hz = frequency_Hz;
            r.amplitude_um = amplitude_um;
            r.amplitude_V = amplitude_V;
            r.offset = offset;
            r.midpoint_um = midpoint_um;
            r.duration_s = duration_s;
            r.sample = sample;
            r.fidelity = fidelity;
            r.substeps = substeps;
            r.log = log;
            r.log_every = log_every;
            return run_sim(scenario, r, axis, holds);
        },
        pyb::arg("scenario"), pyb::arg("case_name"), pyb::arg("trajectory"), pyb::arg("frequency_Hz"),
        pyb::arg("amplitude_um"), pyb::arg("amplitude_V"), pyb::arg("offset"), pyb::arg("midpoint_um"),
        pyb::arg("duration_s"), pyb::arg("sample"), pyb::arg("fidelity"), pyb::arg("substeps"), pyb::arg("log"),
        pyb::arg("log_every"), pyb::arg("axis"), pyb::arg("holds"),
        "One closed-loop run of a scenario case (as `piezoloop sim`): {signals, metrics}; a stage of coupled axes "
        "runs `axis`'s wave while the others hold (holds: \"NAME=UM\" or \"UM\", as --hold-um).");
}

}  // namespace piezoloop::py
