// piezoloop.measure_frf(mimo=True) and piezoloop.analyze_coupling: the n x n
// frequency response of a scenario's coupled axes, as `piezoloop measure frf
// --mimo` measures it (measure/mimo_frf_sim.hpp), and the coupling and
// static decoupling of such a response, as `piezoloop analyze coupling`
// computes them (measure/coupling.hpp, measure/static_decoupling.hpp).
// The response crosses as numpy arrays (lines x outputs x inputs); the CSV
// the command line writes is measure/mimo_frf_file.hpp's, written and read
// by the same code here.
#include <pybind11/complex.h>
#include <pybind11/numpy.h>
#include <pybind11/stl.h>

#include <chrono>
#include <cmath>
#include <complex>
#include <optional>
#include <stdexcept>
#include <string>
#include <vector>

#include <Eigen/Dense>

#include "bindings.hpp"
#include "format/number.hpp"
#include "measure/coupling_report.hpp"
#include "measure/mimo_frf_file.hpp"
#include "measure/mimo_frf_sim.hpp"
#include "measure/static_decoupling.hpp"
#include "sim/scenario.hpp"

namespace piezoloop::py {
namespace {

using nlohmann::json;
using Complex3 = pyb::array_t<std::complex<double>, pyb::array::c_style | pyb::array::forcecast>;
using Real3 = pyb::array_t<double, pyb::array::c_style | pyb::array::forcecast>;

// The C++ messages name the command line's option; here the argument.
[[noreturn]] void rethrow_renamed(const std::invalid_argument& e, const std::string& option, const std::string& arg) {
    const std::string what = e.what();
    if (what.rfind(option, 0) == 0) throw std::invalid_argument(arg + what.substr(option.size()));
    throw e;
}

}  // namespace

pyb::dict estimate_dict(const measure::MimoFrfEstimate& e) {
    const auto lines = static_cast<pyb::ssize_t>(e.frequency_Hz.size());
    const pyb::ssize_t no = e.outputs, ni = e.inputs;
    Complex3 g({lines, no, ni});
    Real3 sd({lines, no, ni}), snr({lines, no, ni});
    auto gw = g.mutable_unchecked<3>();
    auto sw = sd.mutable_unchecked<3>();
    auto nw = snr.mutable_unchecked<3>();
    for (pyb::ssize_t k = 0; k < lines; ++k)
        for (pyb::ssize_t i = 0; i < no; ++i)
            for (pyb::ssize_t j = 0; j < ni; ++j) {
                const auto kk = static_cast<std::size_t>(k);
                gw(k, i, j) = e.response[kk](i, j);
                sw(k, i, j) = e.std_dev[kk](i, j);
                nw(k, i, j) = e.snr_db[kk](i, j);
            }
    pyb::dict out;
    out["frequency_Hz"] = pyb::array_t<double>(lines, e.frequency_Hz.data());
    out["response"] = g;
    out["std"] = sd;
    out["snr_db"] = snr;
    out["inputs"] = e.inputs;
    out["outputs"] = e.outputs;
    out["periods"] = e.periods;
    out["rate_Hz"] = e.rate_Hz;
    return out;
}

namespace {

// The arrays back as an estimate (what the CSV writer and the coupling read).
measure::MimoFrfEstimate estimate_from(const std::vector<double>& f_Hz, const Complex3& g, const Real3& sd,
                                       int periods, double rate_Hz) {
    if (g.ndim() != 3 || g.shape(0) != static_cast<pyb::ssize_t>(f_Hz.size()))
        throw std::invalid_argument("response: must be lines x outputs x inputs, one matrix per frequency");
    if (sd.ndim() != 3 || sd.shape(0) != g.shape(0) || sd.shape(1) != g.shape(1) || sd.shape(2) != g.shape(2))
        throw std::invalid_argument("std: must have the response's shape");
    measure::MimoFrfEstimate e;
    e.outputs = static_cast<int>(g.shape(1));
    e.inputs = static_cast<int>(g.shape(2));
    e.periods = periods;
    e.rate_Hz = rate_Hz;
    e.frequency_Hz = f_Hz;
    auto gr = g.unchecked<3>();
    auto sr = sd.unchecked<3>();
    for (pyb::ssize_t k = 0; k < g.shape(0); ++k) {
        Eigen::MatrixXcd m(e.outputs, e.inputs);
        Eigen::MatrixXd s(e.outputs, e.inputs);
        for (int i = 0; i < e.outputs; ++i)
            for (int j = 0; j < e.inputs; ++j) {
                m(i, j) = gr(k, i, j);
                s(i, j) = sr(k, i, j);
            }
        e.response.push_back(m);
        e.std_dev.push_back(s);
    }
    return e;
}

// The fields `piezoloop analyze coupling` prints (but its file and its
// "meaning" text): measure::coupling_report, with Python's argument names.
json python_coupling_report(const measure::MimoFrfEstimate& e, std::optional<double> below_Hz) {
    try {
        return measure::coupling_report(e, below_Hz);
    } catch (const std::invalid_argument& x) {
        const std::string what = x.what();
        if (what.rfind("below_Hz", 0) == 0) rethrow_renamed(x, "below_Hz", "below_hz");
        throw std::invalid_argument("response: " + what);
    }
}

}  // namespace

void add_measure_mimo(pyb::module_& m) {
    m.def(
        "measure_frf_mimo",
        [](const std::string& scenario, double from_Hz, double to_Hz, double amplitude_V, double bias_V, int periods,
           int transient_periods, std::optional<std::vector<std::vector<double>>> output_matrix) {
            json report;
            measure::MimoFrfSimRun run;
            {
                pyb::gil_scoped_release release;
                const sim::Scenario s = sim::load_scenario(scenario);
                const measure::MimoFrfRequest r =
                    measure::mimo_request(s, from_Hz, to_Hz, amplitude_V, {bias_V}, periods, transient_periods);
                (void)measure::plan_mimo_frf(r);  // refuses before anything runs
                std::optional<Eigen::MatrixXd> d;
                if (output_matrix) {
                    const auto n = static_cast<Eigen::Index>(output_matrix->size());
                    d = Eigen::MatrixXd(n, n);
                    for (Eigen::Index i = 0; i < n; ++i) {
                        const std::vector<double>& row = (*output_matrix)[static_cast<std::size_t>(i)];
                        if (static_cast<Eigen::Index>(row.size()) != n)
                            throw std::invalid_argument("output_matrix: must be " + std::to_string(s.axes.size()) +
                                                        " x " + std::to_string(s.axes.size()) + " (the axes)");
                        for (Eigen::Index j = 0; j < n; ++j) (*d)(i, j) = row[static_cast<std::size_t>(j)];
                    }
                }
                const auto t0 = std::chrono::steady_clock::now();
                try {
                    run = measure::run_mimo_frf_sim(s, r, d);
                } catch (const std::invalid_argument& e) {
                    rethrow_renamed(e, "--output-matrix", "output_matrix");
                }
                const double wall_s = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
                report = measure::mimo_frf_summary(run.estimate);
                json axes = json::array();
                for (const sim::AxisSpec& ax : s.axes) axes.push_back(ax.name);
                report["axes"] = axes;
                report["source"] = {{"kind", "simulator"}, {"scenario", s.name}};
                report["output_matrix"] = d ? "given" : "identity";
                report["clamped_samples"] = run.clamped_samples;
                report["slew_limited_samples"] = run.slew_limited_samples;
                report["simulated_s"] = static_cast<double>(run.plan.block_samples) * run.plan.inputs / s.rate_Hz;
                report["wall_s"] = wall_s;
                report["log_hash"] = format::hex64(run.log_hash);
            }
            pyb::dict out = estimate_dict(run.estimate);
            out["report"] = to_python(report);
            return out;
        },
        pyb::arg("scenario"), pyb::arg("from_Hz"), pyb::arg("to_Hz"), pyb::arg("amplitude_V"), pyb::arg("bias_V"),
        pyb::arg("periods"), pyb::arg("transient_periods"), pyb::arg("output_matrix"));

    m.def(
        "load_mimo_frf",
        [](const std::string& path) { return estimate_dict(measure::load_mimo_frf_file(path)); }, pyb::arg("path"));

    m.def(
        "write_mimo_frf",
        [](const std::string& path, const std::vector<double>& f_Hz, const Complex3& g, const Real3& sd, int periods,
           double rate_Hz) { measure::write_mimo_frf(path, estimate_from(f_Hz, g, sd, periods, rate_Hz)); },
        pyb::arg("path"), pyb::arg("frequency_Hz"), pyb::arg("response"), pyb::arg("std"), pyb::arg("periods"),
        pyb::arg("rate_Hz"));

    m.def(
        "analyze_coupling",
        [](const std::vector<double>& f_Hz, const Complex3& g, std::optional<double> below_Hz) {
            const Real3 none({g.ndim() == 3 ? g.shape(0) : 0, g.ndim() == 3 ? g.shape(1) : 0,
                              g.ndim() == 3 ? g.shape(2) : 0});
            return to_python(python_coupling_report(estimate_from(f_Hz, g, none, 0, 0.0), below_Hz));
        },
        pyb::arg("frequency_Hz"), pyb::arg("response"), pyb::arg("below_Hz"));
}

}  // namespace piezoloop::py
