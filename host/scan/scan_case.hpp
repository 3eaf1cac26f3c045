// A scan as a user asks for it (pattern, size, pixels, line rate, frames,
// sample) on a scenario's case: the request checked and turned into the
// core's ScanConfig, the scan run on the simulator (scan_run.hpp), and its
// figures and images. `piezoloop scan` and piezoloop.scan (Python) both run
// a scan through these functions, so they print the same figures.
//
// How a request becomes a ScanConfig (docs/scan.md):
//   raster     size W x H, NX pixels a line, NY lines a frame at the line
//              rate, turnarounds of 10 % of a line each, the retrace at
//              retrace_speed times the trace's speed; a pixel takes whole
//              ticks, so the line rate run is the nearest that allows;
//   spiral     diameter min(W, H), NY / 2 turns at the line rate as turns a
//              second, pi NX pixels a turn (at most one every two ticks);
//   lissajous  W x H, x at half the line rate, y at (NY - 1) / NY of it;
//   cycloid    W x H, NY lines, NX / 8 circles a line of diameter W / turns;
// centred on the given point or the middle of each axis's travel, and
// refused if it reaches beyond either axis's travel.
#pragma once

#include <cstdint>
#include <functional>
#include <optional>
#include <string>
#include <utility>
#include <vector>

#include <nlohmann/json.hpp>

#include "piezoloop/scan/scan_config.hpp"
#include "scan/sample_surface.hpp"
#include "scan/scan_image.hpp"
#include "scan/scan_run.hpp"
#include "sim/scenario.hpp"

namespace piezoloop::scan {

struct ScanRequest {
    std::string case_name;  // empty: the scenario's first case
    std::string pattern = "raster";
    double size_x_um = 20.0, size_y_um = 20.0;
    int pixels_x = 256, pixels_y = 256;
    double line_rate_Hz = 50.0;
    double retrace_speed = 1.0;  // raster: retrace speed / trace speed, [1, 16]
    int frames = 1;
    std::string sample = "grating:pitch=2,height_nm=50";
    std::optional<std::pair<double, double>> centre_um;  // default: the middle of each axis's travel
};

struct ScanPlan {
    std::string case_name;
    std::string case_label;
    std::string pattern;
    ScanConfig config;
    SampleSurface sample;
    double extent_x_um = 0.0, extent_y_um = 0.0;  // the area the image covers
    int pixels_x = 0, pixels_y = 0;
};

// What a request's field is called where the user wrote it: the command
// line's "--size-um", Python's "size_um". Called with the request's field
// names: scenario, case, pattern, size_um, pixels, line_rate_hz,
// retrace_speed, frames, centre_um, sample.
using FieldName = std::function<std::string(const std::string& field)>;
// The command line's: size_um -> --size-um.
std::string option_name(const std::string& field);

// Where a scan runs: the loop rate, the axes' position scale (Q31) and the
// travel of x and y the scan must stay within.
struct ScanBounds {
    double rate_Hz = 0.0;
    SignalScale position{};
    std::pair<double, double> travel_x_um, travel_y_um;
    std::string whose;  // "axis's travel", "board's position range"
};
// A scenario's: its loop rate and each axis's travel (axis_travel_um).
ScanBounds scenario_bounds(const sim::Scenario& s);

// Checks the request against the scenario; throws std::invalid_argument
// "<field>: <why>" naming the field as `name` spells it.
ScanPlan plan_scan(const sim::Scenario& s, const ScanRequest& r, const FieldName& name);
// The same within given bounds (a board's), without a scenario: the case
// is not used and the centre defaults to the middle of the travel.
ScanPlan plan_scan(const ScanBounds& b, const ScanRequest& r, const FieldName& name);



struct ScanImageSpec {
    std::string file_stem;  // image_commanded, image_measured, error_x, error_y
    std::string title;
    std::string clabel;
    std::string cmap;
    ImageGrid grid;
};

// An image as JSON: {title, clabel, cmap, nx, ny, extent_um: [x_min,
// x_max, y_min, y_max] (cell edges), values: ny x nx row-major, row j at
// y0 + j dy, null where no pixel fell} (tools/plot_image.py's, the console's).
nlohmann::json image_json(const ScanImageSpec& im);

struct ScanOutcome {
    ScanRunResult run;
    nlohmann::json figures;             // what `piezoloop scan` prints (metrics.json)
    std::vector<ScanImageSpec> images;  // of the last frame with pixels; empty if they cannot be formed
    double simulate_wall_s = 0.0;       // wall-clock time of the simulation (printed, never compared)
    double process_wall_s = 0.0;        // of the pixels, figures and images
};

// The figures and images of out.run's ticks (a run's on the simulator or a
// board's record); `stage` names the stage in the figures and the images'
// titles.
void analyse_scan(const ScanPlan& p, double rate_Hz, const std::string& stage, ScanOutcome& out);

// Runs the plan and computes its figures and images. stop_requested and
// progress as in ScanRunOptions (may be empty).
ScanOutcome run_scan_case(const sim::Scenario& s, const ScanPlan& p, std::function<bool()> stop_requested,
                          std::function<void(uint64_t tick, uint64_t total)> progress, bool board_start = false);

}  // namespace piezoloop::scan
