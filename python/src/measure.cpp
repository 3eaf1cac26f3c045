// piezoloop.measure_frf, measure_step, measure_loops (simulator) and the
// Device's (board, device.cpp): `piezoloop measure frf|step|loops` through the
// same host code (measure/frf_sim, measure/step_loops_sim,
// link/measure_session), returning the JSON the command line writes
// (measure/frf_report, measure/step_loops_report).
#include <pybind11/numpy.h>
#include <pybind11/stl.h>

#include <map>

#include <fstream>
#include <optional>
#include <string>

#include "bindings.hpp"
#include "commission_axes.hpp"
#include "commission_session.hpp"
#include "device_common.hpp"
#include "measure/frf_report.hpp"
#include "measure/frf_sim.hpp"
#include "measure/step_loops_sim.hpp"
#include "sim/scenario.hpp"

namespace piezoloop::py {

measure::FrfRequest frf_request(double from_Hz, double to_Hz, double amplitude_V, double bias_V,
                                const std::string& mode, const std::string& signal, int periods,
                                int transient_periods) {
    if (mode != "open" && mode != "closed") throw std::invalid_argument("mode: must be open or closed");
    measure::FrfRequest r;
    r.signal = signal;
    r.from_Hz = from_Hz;
    r.to_Hz = to_Hz;
    r.amplitude_V = amplitude_V;
    r.bias_V = bias_V;
    r.closed = mode == "closed";
    r.periods = periods;
    r.transient_periods = transient_periods;
    return r;
}

measure::StepInput step_options(std::optional<double> step_um, std::optional<double> step_V,
                                  std::optional<double> from_um, std::optional<double> bias_V, const std::string& mode,
                                  double duration_s) {
    measure::StepInput o;
    o.step_um = step_um;
    o.step_V = step_V;
    o.from_um = from_um;
    o.bias_V = bias_V;
    o.mode = mode;
    o.duration_s = duration_s;
    return o;
}

pyb::dict loops_result(const measure::LoopsRun& run, const nlohmann::json& report) {
    auto array = [](const std::vector<double>& v) {
        return pyb::array_t<double>(static_cast<pyb::ssize_t>(v.size()), v.data());
    };
    pyb::dict out;
    out["report"] = to_python(report);
    out["time_s"] = array(run.time_s);
    out["u_V"] = array(run.u_V);
    out["y_um"] = array(run.y_um);
    out["amplitude_V"] = array(run.amplitude_V);
    return out;
}

namespace {

// The simulated stage a measurement runs on, as `--scenario S [--case C]`.
struct SimStage {
    SimStage(const std::string& path, const std::string& case_name, const std::string& sample)
        : scenario(sim::load_scenario(path)),
          case_spec(cli::measured_case(scenario, case_name, sample, storage)),
          bounds(measure::scenario_bounds(scenario)),
          source({{"kind", "simulator"}, {"scenario", scenario.name}, {"case", case_name}, {"rate_Hz", bounds.rate_Hz}}) {}
    sim::Scenario scenario;
    sim::CaseSpec storage;
    const sim::CaseSpec* case_spec;
    measure::MeasureBounds bounds;
    nlohmann::json source;
};

pyb::object measure_frf_sim(const std::string& scenario, const std::string& case_name, const std::string& sample,
                            const measure::FrfRequest& r) {
    nlohmann::json out;
    {
        pyb::gil_scoped_release release;
        const sim::Scenario s = sim::load_scenario(scenario);
        sim::CaseSpec storage;
        const sim::CaseSpec* c = cli::measured_case(s, case_name, sample, storage);
        if (r.closed && case_name.empty()) throw std::invalid_argument("case: closed loop needs the case whose controller closes it");
        const measure::FrfRun run = measure::run_frf_sim(s, c, r);
        std::optional<double> setpoint_um;
        if (r.closed) setpoint_um = r.bias_V * s.command_um_per_V();
        out = measure::frf_report(r, run, {{"kind", "simulator"}, {"scenario", s.name}, {"case", case_name}},
                                  setpoint_um);
    }
    return to_python(out);
}

}  // namespace

void add_measure(pyb::module_& m) {
    m.def(
        "measure_frf",
        [](const std::string& scenario, const std::string& case_name, const std::string& sample, double from_Hz,
           double to_Hz, double amplitude_V, double bias_V, const std::string& mode, const std::string& signal,
           int periods, int transient_periods) {
            return measure_frf_sim(scenario, case_name, sample,
                                   frf_request(from_Hz, to_Hz, amplitude_V, bias_V, mode, signal, periods,
                                               transient_periods));
        },
        pyb::arg("scenario"), pyb::arg("case_name"), pyb::arg("sample"), pyb::arg("from_Hz"), pyb::arg("to_Hz"),
        pyb::arg("amplitude_V"), pyb::arg("bias_V"), pyb::arg("mode"), pyb::arg("signal"), pyb::arg("periods"),
        pyb::arg("transient_periods"));

    m.def(
        "measure_step",
        [](const std::string& scenario, const std::string& case_name, const std::string& sample,
           std::optional<double> step_um, std::optional<double> step_V, std::optional<double> from_um,
           std::optional<double> bias_V, const std::string& mode, double duration_s) {
            nlohmann::json out;
            {
                pyb::gil_scoped_release release;
                const SimStage t(scenario, case_name, sample);
                const measure::StepRequest r = measure::step_request(
                    step_options(step_um, step_V, from_um, bias_V, mode, duration_s), t.bounds, std::nullopt);
                if (r.closed && case_name.empty())
                    throw std::invalid_argument("case: closed loop needs the case whose controller closes it");
                out = measure::step_report(r, measure::run_step_sim(t.scenario, t.case_spec, r), t.source);
            }
            return to_python(out);
        },
        pyb::arg("scenario"), pyb::arg("case_name"), pyb::arg("sample"), pyb::arg("step_um"), pyb::arg("step_V"),
        pyb::arg("from_um"), pyb::arg("bias_V"), pyb::arg("mode"), pyb::arg("duration_s"));

    m.def(
        "measure_loops",
        [](const std::string& scenario, const std::string& case_name, const std::string& sample,
           const std::vector<double>& amplitudes_V, std::optional<double> base_V, double frequency_Hz, int cycles,
           const std::string& shape) {
            std::optional<SimStage> t;
            measure::LoopsRequest r;
            measure::LoopsRun run;
            {
                pyb::gil_scoped_release release;
                t.emplace(scenario, case_name, sample);
                r = measure::loops_request(amplitudes_V, base_V, frequency_Hz, cycles, shape, t->bounds);
                run = measure::run_loops_sim(t->scenario, t->case_spec, r);
            }
            return loops_result(run, measure::loops_report(r, run, t->source));
        },
        pyb::arg("scenario"), pyb::arg("case_name"), pyb::arg("sample"), pyb::arg("amplitudes_V"), pyb::arg("base_V"),
        pyb::arg("frequency_Hz"), pyb::arg("cycles"), pyb::arg("shape"));

    // `piezoloop commission --scenario`: the summary JSON.
    m.def(
        "commission",
        [](const std::string& scenario, double range_um, double target_bandwidth_Hz, const std::string& out,
           const pyb::object& progress) {
            cli::CommissionSession s;
            s.scenario = scenario;
            s.request.range_um = range_um;
            s.request.target_bandwidth_Hz = target_bandwidth_Hz;
            s.out = out;
            const auto say = progress_lines(progress);
            nlohmann::json summary;
            {
                pyb::gil_scoped_release release;
                summary = cli::run_commission_session(nullptr, s, say);
            }
            return to_python(summary);
        },
        pyb::arg("scenario"), pyb::arg("range_um"), pyb::arg("target_bandwidth_Hz"), pyb::arg("out"),
        pyb::arg("progress"));

    // `piezoloop commission --scenario --axes`: the summary JSON.
    m.def(
        "commission_axes",
        [](const std::string& scenario, const std::vector<std::string>& axes,
           const std::map<std::string, double>& range_um, double range_every_um, double target_bandwidth_Hz,
           const std::string& out, const pyb::object& progress) {
            cli::AxesCommission a;
            a.scenario = scenario;
            a.axes = axes;
            a.range_um = range_um;
            a.range_every_um = range_every_um;
            a.request.target_bandwidth_Hz = target_bandwidth_Hz;
            a.out = out;
            const auto say = progress_lines(progress);
            nlohmann::json summary;
            {
                pyb::gil_scoped_release release;
                summary = cli::run_axes_commission(a, say, {});
            }
            return to_python(summary);
        },
        pyb::arg("scenario"), pyb::arg("axes"), pyb::arg("range_um"), pyb::arg("range_every_um"),
        pyb::arg("target_bandwidth_Hz"),
        pyb::arg("out"), pyb::arg("progress"));

    // Loops.save_csv: the CSV through the command line's writer.
    m.def(
        "write_loops_csv",
        [](const std::string& path, std::vector<double> time_s, std::vector<double> u_V, std::vector<double> y_um,
           std::vector<double> amplitude_V) {
            if (u_V.size() != time_s.size() || y_um.size() != time_s.size() || amplitude_V.size() != time_s.size())
                throw std::invalid_argument("loops: time_s, command_v, response_um and amplitude_v differ in length");
            measure::LoopsRun run;
            run.time_s = std::move(time_s);
            run.u_V = std::move(u_V);
            run.y_um = std::move(y_um);
            run.amplitude_V = std::move(amplitude_V);
            std::ofstream f(path);
            if (f) measure::write_loops_csv(f, run);
            if (!f.flush()) throw std::runtime_error(path + ": cannot write");
        },
        pyb::arg("path"), pyb::arg("time_s"), pyb::arg("u_V"), pyb::arg("y_um"), pyb::arg("amplitude_V"));
}

}  // namespace piezoloop::py
