// piezoloop.scan: a scan on the simulator's stage of coupled axes, planned
// and run by scan::plan_scan and scan::run_scan_case exactly as `piezoloop
// scan` runs it, so its figures are the ones the command prints; and the
// result's form for Device.scan (device.cpp).
#include <pybind11/numpy.h>
#include <pybind11/stl.h>

#include <optional>
#include <string>
#include <utility>
#include <vector>

#include "bindings.hpp"
#include "scan/scan_case.hpp"
#include "sim/scenario.hpp"

namespace piezoloop::py {
namespace {

pyb::array_t<double> column(const std::vector<scan::ScanTick>& ticks, double scan::ScanTick::*member) {
    pyb::array_t<double> a(static_cast<pyb::ssize_t>(ticks.size()));
    auto w = a.mutable_unchecked<1>();
    for (std::size_t i = 0; i < ticks.size(); ++i) w(static_cast<pyb::ssize_t>(i)) = ticks[i].*member;
    return a;
}

// An image as a ny x nx array (row j at y0 + j dy; NaN where no pixel fell)
// with the cell-edge extent [x_min, x_max, y_min, y_max] (matplotlib's).
pyb::dict image(const scan::ScanImageSpec& im) {
    const scan::ImageGrid& g = im.grid;
    pyb::array_t<double> a({static_cast<pyb::ssize_t>(g.ny), static_cast<pyb::ssize_t>(g.nx)});
    auto w = a.mutable_unchecked<2>();
    for (int j = 0; j < g.ny; ++j)
        for (int i = 0; i < g.nx; ++i) w(j, i) = g.at(i, j);
    pyb::dict d;
    d["values"] = a;
    d["extent_um"] = std::vector<double>{g.x0_um - g.dx_um / 2, g.x_um(g.nx - 1) + g.dx_um / 2,
                                         g.y0_um - g.dy_um / 2, g.y_um(g.ny - 1) + g.dy_um / 2};
    d["title"] = im.title;
    d["unit"] = im.clabel;
    return d;
}

pyb::dict run(const std::string& scenario, const scan::ScanRequest& req) {
    scan::ScanOutcome r;
    {
        // A frame takes seconds: other Python threads go on meanwhile.
        pyb::gil_scoped_release release;
        const sim::Scenario s = sim::load_scenario(scenario);
        const scan::ScanPlan plan = scan::plan_scan(s, req, [](const std::string& field) { return field; });
        r = scan::run_scan_case(s, plan, {}, {});
    }
    return scan_result(r);
}

}  // namespace

pyb::dict scan_result(const scan::ScanOutcome& r) {
    const std::vector<scan::ScanTick>& t = r.run.ticks;
    pyb::dict ticks;
    ticks["commanded_x_um"] = column(t, &scan::ScanTick::commanded_x_um);
    ticks["commanded_y_um"] = column(t, &scan::ScanTick::commanded_y_um);
    ticks["measured_x_um"] = column(t, &scan::ScanTick::measured_x_um);
    ticks["measured_y_um"] = column(t, &scan::ScanTick::measured_y_um);
    ticks["true_x_um"] = column(t, &scan::ScanTick::true_x_um);
    ticks["true_y_um"] = column(t, &scan::ScanTick::true_y_um);
    ticks["height_nm"] = column(t, &scan::ScanTick::height_nm);
    pyb::array_t<uint32_t> sync(static_cast<pyb::ssize_t>(t.size()));
    auto w = sync.mutable_unchecked<1>();
    for (std::size_t i = 0; i < t.size(); ++i) w(static_cast<pyb::ssize_t>(i)) = t[i].sync;
    ticks["sync"] = sync;
    pyb::dict images;
    for (const scan::ScanImageSpec& im : r.images) images[pyb::str(im.file_stem)] = image(im);
    pyb::dict out;
    out["ticks"] = ticks;
    out["images"] = images;
    out["figures"] = to_python(r.figures);
    return out;
}

scan::ScanRequest scan_request(const std::string& case_name, const std::string& pattern, double size_x_um,
                               double size_y_um, int pixels_x, int pixels_y, double line_rate_Hz, double retrace_speed,
                               int frames, const std::string& sample,
                               std::optional<std::pair<double, double>> centre_um) {
    scan::ScanRequest r;
    r.case_name = case_name;
    r.pattern = pattern;
    r.size_x_um = size_x_um;
    r.size_y_um = size_y_um;
    r.pixels_x = pixels_x;
    r.pixels_y = pixels_y;
    r.line_rate_Hz = line_rate_Hz;
    r.retrace_speed = retrace_speed;
    r.frames = frames;
    r.sample = sample;
    r.centre_um = centre_um;
    return r;
}

void add_scan(pyb::module_& m) {
    m.def(
        "scan",
        [](const std::string& scenario, const std::string& case_name, const std::string& pattern, double size_x_um,
           double size_y_um, int pixels_x, int pixels_y, double line_rate_Hz, double retrace_speed, int frames, const std::string& sample,
           std::optional<std::pair<double, double>> centre_um) {
            return run(scenario, scan_request(case_name, pattern, size_x_um, size_y_um, pixels_x, pixels_y,
                                              line_rate_Hz, retrace_speed, frames, sample, centre_um));
        },
        pyb::arg("scenario"), pyb::arg("case_name"), pyb::arg("pattern"), pyb::arg("size_x_um"),
        pyb::arg("size_y_um"), pyb::arg("pixels_x"), pyb::arg("pixels_y"), pyb::arg("line_rate_Hz"),
        pyb::arg("retrace_speed"), pyb::arg("frames"), pyb::arg("sample"), pyb::arg("centre_um"),
        "A scan on the simulator's stage of coupled axes (as `piezoloop scan`): {ticks, images, figures}");
}

}  // namespace piezoloop::py
