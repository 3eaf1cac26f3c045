// piezoloop.sim: one scenario case run by sim::plan_sim_case and
// sim::run_loop, exactly as `piezoloop sim` runs it (sim/sim_case.hpp), so
// the log hash is the one `piezoloop sim --hash` prints.
#include <pybind11/numpy.h>
#include <pybind11/stl.h>

#include <string>
#include <vector>

#include "bindings.hpp"
#include "sim/closed_loop.hpp"
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

pyb::dict run_sim(const std::string& scenario, const sim::SimCaseRequest& req) {
    sim::Scenario s;
    sim::SimCasePlan plan;
    sim::RunResult r;
    {
        // The run takes seconds; other Python threads go on meanwhile.
        pyb::gil_scoped_release release;
        s = sim::load_scenario(scenario);
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
           double duration_s, const std::string& sample, const std::string& fidelity, int substeps, bool log,
           int log_every) {
            sim::SimCaseRequest r;
            r.case_name = case_name;
            r.trajectory = trajectory;
            r.frequency_Hz = frequency_Hz;
            r.amplitude_um = amplitude_um;
            r.amplitude_V = amplitude_V;
            r.offset = offset;
            r.duration_s = duration_s;
            r.sample = sample;
            r.fidelity = fidelity;
            r.substeps = substeps;
            r.log = log;
            r.log_every = log_every;
            return run_sim(scenario, r);
        },
        pyb::arg("scenario"), pyb::arg("case_name"), pyb::arg("trajectory"), pyb::arg("frequency_Hz"),
        pyb::arg("amplitude_um"), pyb::arg("amplitude_V"), pyb::arg("offset"), pyb::arg("duration_s"),
        pyb::arg("sample"), pyb::arg("fidelity"), pyb::arg("substeps"), pyb::arg("log"), pyb::arg("log_every"),
        "One closed-loop run of a scenario case (as `piezoloop sim`): {signals, metrics}.");
}

}  // namespace piezoloop::py
