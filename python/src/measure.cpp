// piezoloop.measure_frf (simulator) and Device.measure_frf (board): `piezoloop
// measure frf` through the same host code (measure/frf_sim,
// link/measure_session), returning the JSON `measure frf --out` writes
// (measure/frf_report), which `identify tf --frf` reads.
#include <pybind11/stl.h>

#include <optional>
#include <string>

#include "bindings.hpp"
#include "device_common.hpp"
#include "measure/frf_report.hpp"
#include "measure/frf_sim.hpp"
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

namespace {

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
}

}  // namespace piezoloop::py
