// Shared by the binding files of _piezoloop: each adds its functions to the
// module, and JSON crosses to Python through json.loads of the dumped text
// (the same JSON the command line prints, with no second converter to keep
// in step).
#pragma once

#include <pybind11/pybind11.h>

#include <functional>
#include <string>

#include <nlohmann/json.hpp>

#include <optional>

#include "measure/frf_plan.hpp"
#include "measure/mimo_frf_estimate.hpp"
#include "measure/step_loops_plan.hpp"
#include "measure/step_loops_report.hpp"

#include "scan/scan_case.hpp"

namespace piezoloop::py {

namespace pyb = pybind11;

inline pyb::object to_python(const nlohmann::json& j) {
    return pyb::module_::import("json").attr("loads")(j.dump());
}

// A Python callable taking one line (or None) as a progress callback that
// may run with the GIL released: it takes the GIL for the call. `f` must
// outlive the callback (it is held by reference: no reference counting
// without the GIL).
inline std::function<void(const std::string&)> progress_lines(const pyb::object& f) {
    if (f.is_none()) return {};
    return [&f](const std::string& line) {
        pyb::gil_scoped_acquire acquire;
        f(line);
    };
}

void add_sim(pyb::module_& m);
void add_design(pyb::module_& m);
void add_device(pyb::module_& m);
void add_measure(pyb::module_& m);
void add_measure_mimo(pyb::module_& m);
void add_scan(pyb::module_& m);

// An n x n frequency response as {frequency_Hz, response, std, snr_db,
// inputs, outputs, periods, rate_Hz}: arrays of lines x outputs x inputs
// (measure_mimo.cpp).
pyb::dict estimate_dict(const measure::MimoFrfEstimate& e);

// A scan's ticks, images and figures as piezoloop.scan returns them
// (scan.cpp): {"ticks", "images", "figures"}.
pyb::dict scan_result(const scan::ScanOutcome& r);
// A scan request from the Python call's arguments (scan.cpp).
scan::ScanRequest scan_request(const std::string& case_name, const std::string& pattern, double size_x_um,
                               double size_y_um, int pixels_x, int pixels_y, double line_rate_Hz, double retrace_speed,
                               int frames, const std::string& sample,
                               std::optional<std::pair<double, double>> centre_um);

// A `measure frf` request from the Python call's arguments (measure.cpp).
measure::FrfRequest frf_request(double from_Hz, double to_Hz, double amplitude_V, double bias_V,
                                const std::string& mode, const std::string& signal, int periods,
                                int transient_periods);

// A `measure step` request's options from the Python call's arguments.
measure::StepInput step_options(std::optional<double> step_um, std::optional<double> step_V,
                                  std::optional<double> from_um, std::optional<double> bias_V, const std::string& mode,
                                  double duration_s);

// `measure loops`: its report (the --json summary) and the samples of the
// CSV as numpy arrays: {"report", "time_s", "u_V", "y_um", "amplitude_V"}.
pyb::dict loops_result(const measure::LoopsRun& run, const nlohmann::json& report);

}  // namespace piezoloop::py
