// `piezoloop scan`: a frame (or a few) scanned on the simulator's stage of
// coupled axes over an emulated sample (docs/scan.md): the per-tick record
// as CSV, the figures as JSON (also on stdout), the images at commanded and
// at measured positions and the error maps as PNG (tools/plot_image.py).
// Ctrl-C stops the scan, writes what arrived marked incomplete, and exits 4.
#include <chrono>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <iostream>
#include <limits>
#include <memory>
#include <stdexcept>
#include <string>
#include <vector>

#include <nlohmann/json.hpp>

#include "commands.hpp"
#include "device_common.hpp"
#include "piezoloop/scan/scan_generator.hpp"
#include "progress_bar.hpp"
#include "scan/grating_pitch.hpp"
#include "scan/sample_spec.hpp"
#include "scan/scan_csv.hpp"
#include "scan/scan_image.hpp"
#include "scan/scan_metrics.hpp"
#include "scan/scan_pixels.hpp"
#include "scan/scan_run.hpp"
#include "sim/plotting.hpp"
#include "sim/scenario.hpp"
#include "status_text.hpp"

namespace piezoloop::cli {
namespace {

struct ScanArgs {
    std::string scenario;
    std::string case_name;
    std::string pattern = "raster";
    std::string size = "20x20";
    std::string pixels = "256x256";
    double line_rate_Hz = 50.0;
    int frames = 1;
    std::string sample = "grating:pitch=2,height_nm=50";
    std::string centre;
    std::string out;
};

[[noreturn]] void bad(const std::string& option, const std::string& why) {
    throw std::invalid_argument(option + ": " + why);
}

// "AxB" (or "A,B" for the centre) as two numbers.
std::pair<double, double> pair_of(const std::string& option, const std::string& text, char sep, const char* form) {
    const std::size_t at = text.find(sep);
    if (at == std::string::npos) bad(option, std::string("must be ") + form + ", got '" + text + "'");
    auto num = [&](const std::string& t) {
        char* end = nullptr;
        const double v = std::strtod(t.c_str(), &end);
        if (t.empty() || end != t.c_str() + t.size() || !std::isfinite(v))
            bad(option, std::string("must be ") + form + ", got '" + text + "'");
        return v;
    };
    return {num(text.substr(0, at)), num(text.substr(at + 1))};
}

// The generator's field, as the command line names it.
std::string option_of(const char* field) {
    const std::string f = field ? field : "";
    for (const char* s : {"size_x_um", "size_y_um", "radius_um"})
        if (f == s) return "--size-um";
    for (const char* s : {"pixels_per_line", "lines_per_frame", "turns", "turns_per_line"})
        if (f == s) return "--pixels";
    if (f == "frames") return "--frames";
    if (f == "centre_x_um" || f == "centre_y_um") return "--centre-um";
    return "--line-rate-hz";  // rates, frequencies, turnarounds: what the line rate sets
}

struct Plan {
    ScanConfig cfg;
    double extent_x_um = 0.0, extent_y_um = 0.0;  // the scanned area (% of size, the image)
    int nx = 0, ny = 0;
};

Plan plan_scan(const ScanArgs& a, const sim::Scenario& s) {
    Plan p;
    ScanConfig& c = p.cfg;
    const auto [w, h] = pair_of("--size-um", a.size, 'x', "WxH in um, e.g. 20x20");
    if (!(w > 0.0 && w <= 1e6) || !(h > 0.0 && h <= 1e6)) bad("--size-um", "each size must be in (0, 1e6] um");
    const auto [px, py] = pair_of("--pixels", a.pixels, 'x', "NXxNY, e.g. 256x256");
    if (px != std::floor(px) || py != std::floor(py) || px < 2 || py < 2 || px > 4096 || py > 4096)
        bad("--pixels", "each count must be a whole number in [2, 4096]");
    if (!(a.line_rate_Hz > 0.0) || !(a.line_rate_Hz <= s.setup.rate_Hz / 4.0))
        bad("--line-rate-hz", "must be in (0, " + std::to_string(s.setup.rate_Hz / 4.0) + "] Hz (the loop rate / 4)");
    if (a.frames < 1 || a.frames > 1000) bad("--frames", "must be in [1, 1000]");
    p.nx = static_cast<int>(px);
    p.ny = static_cast<int>(py);
    const float rate = static_cast<float>(a.line_rate_Hz);
    c.sample_rate_Hz = s.setup.rate_Hz;
    c.frames = static_cast<uint32_t>(a.frames);
    c.pixels_per_line = static_cast<uint32_t>(p.nx);
    p.extent_x_um = w;
    p.extent_y_um = h;
    if (a.pattern == "raster") {
        c.pattern = ScanPattern::kRaster;
        c.size_x_um = static_cast<float>(w);
        c.size_y_um = static_cast<float>(h);
        c.lines_per_frame = static_cast<uint32_t>(p.ny);
        c.line_rate_Hz = rate;
        c.turnaround_s = static_cast<float>(0.1 / a.line_rate_Hz);  // 10 % of a line each
    } else if (a.pattern == "spiral") {
        c.pattern = ScanPattern::kSpiral;
        const double d = std::min(w, h);
        c.radius_um = static_cast<float>(d / 2.0);
        c.turns = static_cast<uint32_t>(std::max(1, p.ny / 2));
        c.turn_rate_Hz = rate;
        // pi NX pixels a turn (the outer turn's spacing one cell), at most
        // one every two ticks.
        const double most = std::floor(s.setup.rate_Hz / (2.0 * a.line_rate_Hz));
        c.pixels_per_line = static_cast<uint32_t>(std::max(1.0, std::min(std::ceil(M_PI * p.nx), most)));
        p.extent_x_um = p.extent_y_um = d;
    } else if (a.pattern == "lissajous") {
        c.pattern = ScanPattern::kLissajous;
        c.size_x_um = static_cast<float>(w);
        c.size_y_um = static_cast<float>(h);
        c.frequency_x_Hz = rate / 2.0f;  // a line is half a period of x
        c.frequency_y_Hz = static_cast<float>(a.line_rate_Hz / 2.0 * (p.ny - 1) / p.ny);
    } else if (a.pattern == "cycloid") {
        c.pattern = ScanPattern::kCycloid;
        c.size_x_um = static_cast<float>(w);
        c.size_y_um = static_cast<float>(h);
        c.lines_per_frame = static_cast<uint32_t>(p.ny);
        c.turns_per_line = static_cast<uint32_t>(std::max(1, p.nx / 8));
        c.radius_um = static_cast<float>(w / c.turns_per_line / 2.0);
        c.turn_rate_Hz = static_cast<float>(a.line_rate_Hz * c.turns_per_line);
        p.extent_x_um = w + 2.0 * c.radius_um;
        p.extent_y_um = h + 2.0 * c.radius_um;
    } else {
        bad("--pattern", "must be raster, spiral, lissajous or cycloid, got '" + a.pattern + "'");
    }
    // The centre: given, or the middle of each axis's travel.
    const auto tx = scan::axis_travel_um(s, 0), ty = scan::axis_travel_um(s, 1);
    if (a.centre.empty()) {
        c.centre_x_um = static_cast<float>(0.5 * (tx.first + tx.second));
        c.centre_y_um = static_cast<float>(0.5 * (ty.first + ty.second));
    } else {
        const auto [cx, cy] = pair_of("--centre-um", a.centre, ',', "X,Y in um, e.g. 50,50");
        c.centre_x_um = static_cast<float>(cx);
        c.centre_y_um = static_cast<float>(cy);
    }
    ScanGenerator<float> g(s.setup.position, s.setup.position, s.setup.position);
    if (const Status st = g.configure(c); !st.ok()) bad(option_of(st.field), describe(st));
    const double reach = g.reach_um();
    const std::pair<double, double> travel[2] = {tx, ty};
    const double centre[2] = {c.centre_x_um, c.centre_y_um};
    for (int i = 0; i < 2; ++i)
        if (centre[i] - reach < travel[i].first || centre[i] + reach > travel[i].second)
            bad(a.centre.empty() ? "--size-um" : "--size-um / --centre-um",
                std::string("the scan reaches ") + (i == 0 ? "x" : "y") + " in [" + std::to_string(centre[i] - reach) +
                    ", " + std::to_string(centre[i] + reach) + "] um, beyond the axis's travel [" +
                    std::to_string(travel[i].first) + ", " + std::to_string(travel[i].second) + "] um");
    return p;
}

nlohmann::json number(double v) { return std::isfinite(v) ? nlohmann::json(v) : nlohmann::json(nullptr); }

nlohmann::json image_spec(const scan::ImageGrid& g, const std::string& out, const std::string& title,
                          const std::string& clabel, const char* cmap) {
    nlohmann::json values = nlohmann::json::array();
    for (const double v : g.value) values.push_back(number(v));
    return {{"out", out},
            {"title", title},
            {"clabel", clabel},
            {"cmap", cmap},
            {"nx", g.nx},
            {"ny", g.ny},
            {"extent_um", {g.x0_um - g.dx_um / 2, g.x_um(g.nx - 1) + g.dx_um / 2, g.y0_um - g.dy_um / 2,
                           g.y_um(g.ny - 1) + g.dy_um / 2}},
            {"values", values}};
}

int run(const ScanArgs& a) {
    const sim::Scenario s = sim::load_scenario(a.scenario);
    if (s.axes.size() < 2) bad("--scenario", "a scan needs a stage of two or three axes (plant.axes)");
    if (s.cases.empty()) bad("--case", "the scenario has no cases");
    const std::string case_name = a.case_name.empty() ? s.cases.front().name : a.case_name;
    const sim::CaseSpec* chosen = nullptr;
    for (const sim::CaseSpec& c : s.cases)
        if (c.name == case_name) chosen = &c;
    if (chosen == nullptr) {
        std::string names;
        for (const sim::CaseSpec& c : s.cases) names += (names.empty() ? "" : ", ") + c.name;
        bad("--case", "'" + case_name + "' is not a case of the scenario (" + names + ")");
    }
    const Plan plan = plan_scan(a, s);
    scan::SampleSurface sample;
    try {
        sample = scan::parse_sample_spec(a.sample);
    } catch (const std::invalid_argument& e) {
        bad("--sample", e.what());
    }
    const std::filesystem::path dir(a.out);
    std::filesystem::create_directories(dir);

    const StopSignals stop_signals;
    scan::ScanRunOptions o;
    o.case_name = case_name;
    o.scan = plan.cfg;
    o.sample = sample;
    o.stop_requested = [] { return StopSignals::requested(); };
    const auto t0 = std::chrono::steady_clock::now();
    bool shown = false;
    o.progress = [&](uint64_t k, uint64_t total) {
        progress_bar(total ? std::min(1.0, static_cast<double>(k) / static_cast<double>(total)) : 1.0, t0, shown);
    };
    const scan::ScanRunResult r = scan::run_scan(s, o);
    const double rate = s.setup.rate_Hz;
    const bool raster = plan.cfg.pattern == ScanPattern::kRaster;

    const std::vector<scan::ScanPixel> px = scan::form_pixels(r.ticks);
    const scan::ScanMetrics m = scan::compute_metrics(r.ticks, px, rate, raster);
    scan::write_scan_csv(dir / "scan.csv", r.ticks);

    ScanGenerator<float> g(s.setup.position, s.setup.position, s.setup.position);
    (void)g.configure(plan.cfg);  // accepted by plan_scan already
    const double line_Hz = g.line_period_ticks() ? rate / g.line_period_ticks() : 0.0;

    auto pct = [](double v, double size) { return number(100.0 * v / size); };
    nlohmann::json j = {
        {"scenario", s.name},
        {"case", case_name},
        {"case_label", chosen->label},
        {"sample_type", r.q31 ? "q31" : "float"},
        {"pattern", a.pattern},
        {"sample", sample.describe()},
        {"centre_um", {plan.cfg.centre_x_um, plan.cfg.centre_y_um}},
        {"size_um", {plan.extent_x_um, plan.extent_y_um}},
        {"image_cells", {plan.nx, plan.ny}},
        {"pixels_per_line", plan.cfg.pixels_per_line},
        {"lines_per_frame", g.lines_per_frame()},
        {"line_rate_Hz", number(line_Hz)},
        {"rate_Hz", rate},
        {"frames_requested", a.frames},
        {"frames_completed", r.frames_completed},
        {"complete", r.complete},
        {"approach_ticks", r.approach_ticks},
        {"csv", "scan.csv: one row a tick from the scan's first tick (after the approach)"},
        {"ticks", m.ticks},
        {"used_ticks", m.used_ticks},
        {"pixels", m.pixels},
        {"lines", m.lines},
        {"tracking",
         {{"rms_x_um", m.rms_error_x_um},
          {"max_x_um", m.max_error_x_um},
          {"rms_y_um", m.rms_error_y_um},
          {"max_y_um", m.max_error_y_um},
          {"rms_x_percent", pct(m.rms_error_x_um, plan.extent_x_um)},
          {"max_x_percent", pct(m.max_error_x_um, plan.extent_x_um)},
          {"rms_y_percent", pct(m.rms_error_y_um, plan.extent_y_um)},
          {"max_y_percent", pct(m.max_error_y_um, plan.extent_y_um)}}},
        {"used_fraction", number(m.used_fraction)},
        {"linearity_um", number(m.linearity_um)},
        {"linearity_percent", pct(m.linearity_um, plan.extent_x_um)},
        {"frame_time_s", m.frame_time_s},
    };

    // Images of the last frame that has pixels.
    uint32_t frame = 0;
    for (const scan::ScanPixel& p : px) frame = std::max(frame, p.frame);
    j["image_frame"] = frame;
    nlohmann::json images = nlohmann::json::array();
    try {
        auto grid = [&] {
            return raster ? scan::raster_grid(px, frame)
                          : scan::area_grid(plan.cfg.centre_x_um, plan.cfg.centre_y_um, plan.extent_x_um,
                                            plan.extent_y_um, plan.nx, plan.ny);
        };
        auto form = [&](scan::Placement where, scan::Quantity what) {
            scan::ImageGrid im = grid();
            if (raster) scan::place_by_lines(im, px, frame, where, what);
            else scan::place_by_cells(im, px, frame, where, what);
            return im;
        };
        const scan::ImageGrid commanded = form(scan::Placement::kCommanded, scan::Quantity::kHeight);
        const scan::ImageGrid measured = form(scan::Placement::kMeasured, scan::Quantity::kHeight);
        const scan::ImageGrid ex = form(scan::Placement::kCommanded, scan::Quantity::kErrorX);
        const scan::ImageGrid ey = form(scan::Placement::kCommanded, scan::Quantity::kErrorY);
        const std::string what = a.pattern + " on " + s.name + ", " + sample.describe();
        images.push_back(image_spec(commanded, (dir / "image_commanded.png").string(),
                                    "at commanded positions\n" + what, "height (nm)", "viridis"));
        images.push_back(image_spec(measured, (dir / "image_measured.png").string(),
                                    "at measured positions\n" + what, "height (nm)", "viridis"));
        images.push_back(image_spec(ex, (dir / "error_x.png").string(), "x: commanded - measured", "um", "coolwarm"));
        images.push_back(image_spec(ey, (dir / "error_y.png").string(), "y: commanded - measured", "um", "coolwarm"));
        if (sample.kind == scan::SurfaceKind::kGrating) {
            const scan::GratingFit fc = scan::fit_grating(commanded), fm = scan::fit_grating(measured);
            j["pitch"] = {{"sample_um", sample.pitch_um},
                          {"commanded_um", number(fc.pitch_um)},
                          {"measured_um", number(fm.pitch_um)},
                          {"commanded_error_percent", number(100.0 * (fc.pitch_um / sample.pitch_um - 1.0))},
                          {"measured_error_percent", number(100.0 * (fm.pitch_um / sample.pitch_um - 1.0))},
                          {"crossings_commanded", fc.crossings},
                          {"crossings_measured", fm.crossings}};
        }
    } catch (const std::invalid_argument& e) {
        j["images_skipped"] = e.what();
    }
    {
        std::ofstream f(dir / "metrics.json");
        f << j.dump(1) << "\n";
        if (!f) throw std::runtime_error((dir / "metrics.json").string() + ": cannot be written");
    }
    if (!images.empty()) sim::plot_spec("plot_image.py", {{"images", images}});
    std::cout << j.dump(1) << "\n";
    std::fprintf(stderr, "scan: %s, %zu ticks (%.3f s of stage time), %zu pixels; wrote %s\n",
                 r.complete ? "complete" : "stopped early", m.ticks, static_cast<double>(m.ticks) / rate, m.pixels,
                 dir.c_str());
    if (!r.complete)
        throw LostData("scan interrupted (Ctrl-C or SIGTERM): what arrived is written, marked incomplete in "
                       "metrics.json");
    return 0;
}

}  // namespace

void add_scan(CLI::App& app) {
    auto a = std::make_shared<ScanArgs>();
    CLI::App* cmd = app.add_subcommand(
        "scan", "Scan a frame on the simulator's XY stage over an emulated sample: images, errors and figures");
    cmd->add_option("--scenario", a->scenario, "scenario of two or three axes (configs/stages/*.json)")
        ->required()
        ->check(CLI::ExistingFile);
    cmd->add_option("--case", a->case_name, "controller case of the scenario (default: its first)");
    cmd->add_option("--pattern", a->pattern, "raster | spiral | lissajous | cycloid (docs/scan.md)");
    cmd->add_option("--size-um", a->size, "scan size WxH in um (spiral: diameter min(W, H)), default 20x20");
    cmd->add_option("--pixels", a->pixels, "image NXxNY (raster: pixels a line x lines), default 256x256");
    cmd->add_option("--line-rate-hz", a->line_rate_Hz, "lines per second (spiral: turns per second), default 50");
    cmd->add_option("--frames", a->frames, "frames to scan, 1 to 1000 (default 1)");
    cmd->add_option("--sample", a->sample,
                    "grating:pitch=2,height_nm=50,duty=0.5 | step:x=50,height_nm=50 | dots:pitch=2,radius=0.5,height_nm=20");
    cmd->add_option("--centre-um", a->centre, "scan centre X,Y in um (default: the middle of each axis's travel)");
    cmd->add_option("--out", a->out, "output folder: scan.csv, metrics.json, image_*.png, error_*.png")->required();
    cmd->callback([a] { guarded([&] { return run(*a); }); });
}

namespace {
const bool registered = register_command(42, add_scan);
}  // namespace

}  // namespace piezoloop::cli
