#include "scan/scan_case.hpp"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <stdexcept>

#include "piezoloop/scan/scan_generator.hpp"
#include "scan/grating_pitch.hpp"
#include "scan/sample_spec.hpp"
#include "scan/scan_metrics.hpp"
#include "scan/scan_pixels.hpp"
#include "sim/rc_check.hpp"
#include "status_text.hpp"

namespace piezoloop::scan {
namespace {

// x's and y's repetitive controllers: the stability conditions of their
// linearised loops at the scan's periods (sim/rc_check.hpp), where the
// case is of a form the analysis covers. The exact check (eigenvalues,
// O(N^3): 45 s at N = 1948) only for periods up to 512 ticks; the
// small-gain condition, sufficient, for every period.
constexpr int kMaxExactRcDelayStates = 512;

nlohmann::json rc_stability(const sim::Scenario& s, const ScanPlan& p) {
    nlohmann::json j = nlohmann::json::object();
    const sim::CaseSpec& c = s.find_case(p.case_name);
    for (std::size_t i = 0; i < 2 && i < s.axes.size(); ++i) {
        const sim::CaseSpec& ac = c.axis_cases.empty() ? c : c.axis_cases[i];
        const uint32_t period = scan_rc_period_ticks(p.config, static_cast<int>(i));
        const std::optional<design::RcAnalysis> a =
            sim::rc_conditions(sim::axis_alone(s, i), ac, s.rate_Hz / static_cast<double>(period), kMaxExactRcDelayStates);
        if (!a) continue;
        nlohmann::json& x = j[s.axes[i].name];
        x = {{"period_ticks", a->period_samples},
             {"loop_stable", a->loop_stable},
             {"small_gain_peak", a->small_gain_peak},
             {"small_gain_at_Hz", a->small_gain_at_Hz},
             {"small_gain_ok", a->small_gain_ok}};
        if (a->rc_max_abs_root) x["max_abs_root"] = *a->rc_max_abs_root;
        x["stable"] = a->rc_stable ? nlohmann::json(*a->rc_stable) : nlohmann::json(nullptr);
    }
    return j;
}

// The request's field that sets a generator's field.
std::string request_field(const char* field) {
    const std::string f = field ? field : "";
    for (const char* s : {"size_x_um", "size_y_um", "radius_um"})
        if (f == s) return "size_um";
    for (const char* s : {"pixels_per_line", "lines_per_frame", "turns", "turns_per_line"})
        if (f == s) return "pixels";
    if (f == "frames") return "frames";
    if (f == "retrace_speed_factor") return "retrace_speed";
    if (f == "centre_x_um" || f == "centre_y_um") return "centre_um";
    return "line_rate_hz";  // rates, frequencies, turnarounds: what the line rate sets
}

nlohmann::json number(double v) { return std::isfinite(v) ? nlohmann::json(v) : nlohmann::json(nullptr); }

}  // namespace

std::string option_name(const std::string& field) {
    std::string o = "--" + field;
    std::replace(o.begin(), o.end(), '_', '-');
    return o;
}

nlohmann::json image_json(const ScanImageSpec& im) {
    const ImageGrid& g = im.grid;
    nlohmann::json values = nlohmann::json::array();
    for (const double v : g.value) values.push_back(std::isfinite(v) ? nlohmann::json(v) : nlohmann::json(nullptr));
    return {{"title", im.title},
            {"clabel", im.clabel},
            {"cmap", im.cmap},
            {"nx", g.nx},
            {"ny", g.ny},
            {"extent_um", {g.x0_um - g.dx_um / 2, g.x_um(g.nx - 1) + g.dx_um / 2, g.y0_um - g.dy_um / 2,
                           g.y_um(g.ny - 1) + g.dy_um / 2}},
            {"values", values}};
}

ScanBounds scenario_bounds(const sim::Scenario& s) {
    ScanBounds b;
    b.rate_Hz = s.setup.rate_Hz;
    b.position = s.setup.position;
    b.travel_x_um = axis_travel_um(s, 0);
    b.travel_y_um = axis_travel_um(s, 1);
    b.whose = "axis's travel";
    return b;
}

ScanPlan plan_scan(const sim::Scenario& s, const ScanRequest& r, const FieldName& name) {
    auto bad = [&](const std::string& field, const std::string& why) {
        throw std::invalid_argument(name(field) + ": " + why);
    };
    if (s.axes.size() < 2) bad("scenario", "a scan needs a stage of two or three axes (plant.axes)");
    if (s.cases.empty()) bad("case", "the scenario has no cases");
    const std::string case_name = r.case_name.empty() ? s.cases.front().name : r.case_name;
    const sim::CaseSpec* chosen = nullptr;
    for (const sim::CaseSpec& c : s.cases)
        if (c.name == case_name) chosen = &c;
    if (chosen == nullptr) {
        std::string names;
        for (const sim::CaseSpec& c : s.cases) names += (names.empty() ? "" : ", ") + c.name;
        bad("case", "'" + case_name + "' is not a case of the scenario (" + names + ")");
    }
    ScanPlan p = plan_scan(scenario_bounds(s), r, name);
    p.case_name = case_name;
    p.case_label = chosen->label;
    return p;
}

ScanPlan plan_scan(const ScanBounds& b, const ScanRequest& r, const FieldName& name) {
    auto bad = [&](const std::string& field, const std::string& why) {
        throw std::invalid_argument(name(field) + ": " + why);
    };
    ScanPlan p;
    p.pattern = r.pattern;

    const double w = r.size_x_um, h = r.size_y_um;
    if (!(w > 0.0 && w <= 1e6) || !(h > 0.0 && h <= 1e6)) bad("size_um", "each size must be in (0, 1e6] um");
    if (r.pixels_x < 2 || r.pixels_y < 2 || r.pixels_x > 4096 || r.pixels_y > 4096)
        bad("pixels", "each count must be a whole number in [2, 4096]");
    if (!(r.line_rate_Hz > 0.0) || !(r.line_rate_Hz <= b.rate_Hz / 4.0))
        bad("line_rate_hz", "must be in (0, " + std::to_string(b.rate_Hz / 4.0) + "] Hz (the loop rate / 4)");
    if (r.frames < 1 || r.frames > 1000) bad("frames", "must be in [1, 1000]");
    if (!(r.retrace_speed >= 1.0 && r.retrace_speed <= 16.0)) bad("retrace_speed", "must be in [1, 16]");
    if (r.retrace_speed != 1.0 && r.pattern != "raster") bad("retrace_speed", "applies to a raster only");
    try {
        p.sample = parse_sample_spec(r.sample);
    } catch (const std::invalid_argument& e) {
        bad("sample", e.what());
    }

    ScanConfig& c = p.config;
    p.pixels_x = r.pixels_x;
    p.pixels_y = r.pixels_y;
    const float rate = static_cast<float>(r.line_rate_Hz);
    c.sample_rate_Hz = b.rate_Hz;
    c.frames = static_cast<uint32_t>(r.frames);
    c.pixels_per_line = static_cast<uint32_t>(p.pixels_x);
    p.extent_x_um = w;
    p.extent_y_um = h;
    if (r.pattern == "raster") {
        c.pattern = ScanPattern::kRaster;
        c.size_x_um = static_cast<float>(w);
        c.size_y_um = static_cast<float>(h);
        c.lines_per_frame = static_cast<uint32_t>(p.pixels_y);
        c.line_rate_Hz = rate;
        c.turnaround_s = static_cast<float>(0.1 / r.line_rate_Hz);  // 10 % of a line each
        c.retrace_speed_factor = static_cast<float>(r.retrace_speed);
    } else if (r.pattern == "spiral") {
        c.pattern = ScanPattern::kSpiral;
        const double d = std::min(w, h);
        c.radius_um = static_cast<float>(d / 2.0);
        c.turns = static_cast<uint32_t>(std::max(1, p.pixels_y / 2));
        c.turn_rate_Hz = rate;
        // pi NX pixels a turn (the outer turn's spacing one cell), at most
        // one every two ticks.
        const double most = std::floor(b.rate_Hz / (2.0 * r.line_rate_Hz));
        c.pixels_per_line = static_cast<uint32_t>(std::max(1.0, std::min(std::ceil(M_PI * p.pixels_x), most)));
        p.extent_x_um = p.extent_y_um = d;
    } else if (r.pattern == "lissajous") {
        c.pattern = ScanPattern::kLissajous;
        c.size_x_um = static_cast<float>(w);
        c.size_y_um = static_cast<float>(h);
        c.frequency_x_Hz = rate / 2.0f;  // a line is half a period of x
        c.frequency_y_Hz = static_cast<float>(r.line_rate_Hz / 2.0 * (p.pixels_y - 1) / p.pixels_y);
        // When x repeats after whole ticks, y's period is rounded to whole
        // ticks too, so each axis's repetitive controller can learn over its
        // own sinusoid (ScanGenerator::lissajous_axis_period_ticks).
        const double ticks_x = b.rate_Hz / static_cast<double>(c.frequency_x_Hz);
        if (p.pixels_y > 1 && ticks_x == std::round(ticks_x)) {
            double ticks_y = std::round(ticks_x * p.pixels_y / (p.pixels_y - 1));
            if (ticks_y == ticks_x) ticks_y += 1.0;
            c.frequency_y_Hz = static_cast<float>(b.rate_Hz / ticks_y);
        }
    } else if (r.pattern == "cycloid") {
        c.pattern = ScanPattern::kCycloid;
        c.size_x_um = static_cast<float>(w);
        c.size_y_um = static_cast<float>(h);
        c.lines_per_frame = static_cast<uint32_t>(p.pixels_y);
        c.turns_per_line = static_cast<uint32_t>(std::max(1, p.pixels_x / 8));
        c.radius_um = static_cast<float>(w / c.turns_per_line / 2.0);
        c.turn_rate_Hz = static_cast<float>(r.line_rate_Hz * c.turns_per_line);
        p.extent_x_um = w + 2.0 * c.radius_um;
        p.extent_y_um = h + 2.0 * c.radius_um;
    } else {
        bad("pattern", "must be raster, spiral, lissajous or cycloid, got '" + r.pattern + "'");
    }
    // The centre: given, or the middle of each axis's travel.
    const auto tx = b.travel_x_um, ty = b.travel_y_um;
    if (!r.centre_um) {
        c.centre_x_um = static_cast<float>(0.5 * (tx.first + tx.second));
        c.centre_y_um = static_cast<float>(0.5 * (ty.first + ty.second));
    } else {
        if (!std::isfinite(r.centre_um->first) || !std::isfinite(r.centre_um->second))
            bad("centre_um", "must be two finite numbers");
        c.centre_x_um = static_cast<float>(r.centre_um->first);
        c.centre_y_um = static_cast<float>(r.centre_um->second);
    }
    ScanGenerator<float> g(b.position, b.position, b.position);
    if (const Status st = g.configure(c); !st.ok()) bad(request_field(st.field), describe(st));
    // Every tick of a scan is kept (64 bytes each) and written to scan.csv.
    constexpr uint64_t kMaxScanTicks = uint64_t{1} << 25;  // 2 GiB of ticks
    const uint64_t ticks = uint64_t{g.frame_period_ticks()} * c.frames;
    if (ticks > kMaxScanTicks) {
        const std::string why = "the scan lasts " + std::to_string(ticks) + " ticks (" + std::to_string(c.frames) +
                                " frames of " + std::to_string(g.frame_period_ticks()) + "), more than the " +
                                std::to_string(kMaxScanTicks) + " a scan records";
        if (c.frames > 1) bad("frames", "must be fewer: " + why);
        bad("pixels", "a frame too long: " + why + " (fewer pixels or lines, or a faster line rate)");
    }
    const double reach = g.reach_um();
    const std::pair<double, double> travel[2] = {tx, ty};
    const double centre[2] = {c.centre_x_um, c.centre_y_um};
    for (int i = 0; i < 2; ++i)
        if (centre[i] - reach < travel[i].first || centre[i] + reach > travel[i].second) {
            const std::string field = r.centre_um ? name("size_um") + " / " + name("centre_um") : name("size_um");
            throw std::invalid_argument(
                field + ": the scan reaches " + (i == 0 ? "x" : "y") + " in [" + std::to_string(centre[i] - reach) +
                ", " + std::to_string(centre[i] + reach) + "] um, beyond the " + b.whose + " [" +
                std::to_string(travel[i].first) + ", " + std::to_string(travel[i].second) + "] um");
        }
    return p;
}

ScanOutcome run_scan_case(const sim::Scenario& s, const ScanPlan& p, std::function<bool()> stop_requested,
                          std::function<void(uint64_t tick, uint64_t total)> progress, bool board_start) {
    ScanRunOptions o;
    o.board_start = board_start;
    o.case_name = p.case_name;
    o.scan = p.config;
    o.sample = p.sample;
    o.stop_requested = std::move(stop_requested);
    o.progress = std::move(progress);
    ScanOutcome out;
    using Clock = std::chrono::steady_clock;
    const Clock::time_point t0 = Clock::now();
    out.run = run_scan(s, o);
    out.simulate_wall_s = std::chrono::duration<double>(Clock::now() - t0).count();
    analyse_scan(p, s.setup.rate_Hz, s.name, out);
    if (nlohmann::json rc = rc_stability(s, p); !rc.empty()) out.figures["rc_stability"] = std::move(rc);
    return out;
}

void analyse_scan(const ScanPlan& p, double rate, const std::string& stage, ScanOutcome& out) {
    using Clock = std::chrono::steady_clock;
    const Clock::time_point t1 = Clock::now();
    const ScanRunResult& r = out.run;
    const bool raster = p.config.pattern == ScanPattern::kRaster;

    const std::vector<ScanPixel> px = form_pixels(r.ticks);
    const ScanMetrics m = compute_metrics(r.ticks, px, rate, raster);
    ScanGenerator<float> g;
    (void)g.configure(p.config);  // accepted by plan_scan already
    // Lines of one length (raster, cycloid, CAV spiral); a Lissajous line is
    // half a period of x, which need not be whole ticks; else 0 (CLV spiral).
    double line_Hz = g.line_period_ticks() ? rate / g.line_period_ticks() : 0.0;
    if (p.config.pattern == ScanPattern::kLissajous) line_Hz = rate * g.lines_per_frame() / g.frame_period_ticks();

    auto pct = [](double v, double size) { return number(100.0 * v / size); };
    auto tracking_json = [&](const ScanTracking& t) {
        return nlohmann::json{{"rms_x_um", t.rms_x_um},
                              {"max_x_um", t.max_x_um},
                              {"rms_y_um", t.rms_y_um},
                              {"max_y_um", t.max_y_um},
                              {"rms_x_percent", pct(t.rms_x_um, p.extent_x_um)},
                              {"max_x_percent", pct(t.max_x_um, p.extent_x_um)},
                              {"rms_y_percent", pct(t.rms_y_um, p.extent_y_um)},
                              {"max_y_percent", pct(t.max_y_um, p.extent_y_um)}};
    };
    nlohmann::json& j = out.figures;
    j = {
        {"scenario", stage},
        {"case", p.case_name},
        {"case_label", p.case_label},
        {"sample_type", r.q31 ? "q31" : "float"},
        {"pattern", p.pattern},
        {"sample", p.sample.describe()},
        {"centre_um", {p.config.centre_x_um, p.config.centre_y_um}},
        {"size_um", {p.extent_x_um, p.extent_y_um}},
        {"image_cells", {p.pixels_x, p.pixels_y}},
        {"pixels_per_line", p.config.pixels_per_line},
        {"lines_per_frame", g.lines_per_frame()},
        {"line_rate_Hz", number(line_Hz)},
        {"rate_Hz", rate},
        {"frames_requested", p.config.frames},
        {"frames_completed", r.frames_completed},
        {"complete", r.complete},
        {"approach_ticks", r.approach_ticks},
        {"ticks", m.ticks},
        {"used_ticks", m.tracking.used_ticks},
        {"pixels", m.pixels},
        {"lines", m.lines},
        {"tracking", tracking_json(m.tracking)},
        {"tracking_last_frame", tracking_json(m.last_frame)},
        {"last_frame", m.last_frame_index},
        {"used_fraction", number(m.used_fraction)},
        {"linearity_um", number(m.linearity_um)},
        {"linearity_percent", pct(m.linearity_um, p.extent_x_um)},
        {"frame_time_s", m.frame_time_s},
    };

    if (raster) j["retrace_speed"] = p.config.retrace_speed_factor;

    // Images of the last frame that has pixels.
    uint32_t frame = 0;
    for (const ScanPixel& q : px) frame = std::max(frame, q.frame);
    j["image_frame"] = frame;
    try {
        auto form = [&](Placement where, Quantity what) {
            ImageGrid im = raster ? raster_grid(px, frame)
                                  : area_grid(p.config.centre_x_um, p.config.centre_y_um, p.extent_x_um,
                                              p.extent_y_um, p.pixels_x, p.pixels_y);
            if (raster) place_by_lines(im, px, frame, where, what);
            else place_by_cells(im, px, frame, where, what);
            return im;
        };
        const std::string what = p.pattern + " on " + stage + ", " + p.sample.describe();
        out.images.push_back({"image_commanded", "at commanded positions\n" + what, "height (nm)", "viridis",
                              form(Placement::kCommanded, Quantity::kHeight)});
        out.images.push_back({"image_measured", "at measured positions\n" + what, "height (nm)", "viridis",
                              form(Placement::kMeasured, Quantity::kHeight)});
        out.images.push_back({"error_x", "x: commanded - measured", "um", "coolwarm",
                              form(Placement::kCommanded, Quantity::kErrorX)});
        out.images.push_back({"error_y", "y: commanded - measured", "um", "coolwarm",
                              form(Placement::kCommanded, Quantity::kErrorY)});
        if (p.sample.kind == SurfaceKind::kGrating) {
            const GratingFit fc = fit_grating(out.images[0].grid), fm = fit_grating(out.images[1].grid);
            j["pitch"] = {{"sample_um", p.sample.pitch_um},
                          {"commanded_um", number(fc.pitch_um)},
                          {"measured_um", number(fm.pitch_um)},
                          {"commanded_error_percent", number(100.0 * (fc.pitch_um / p.sample.pitch_um - 1.0))},
                          {"measured_error_percent", number(100.0 * (fm.pitch_um / p.sample.pitch_um - 1.0))},
                          {"crossings_commanded", fc.crossings},
                          {"crossings_measured", fm.crossings}};
        }
    } catch (const std::invalid_argument& e) {
        out.images.clear();
        j["images_skipped"] = e.what();
    }
    out.process_wall_s = std::chrono::duration<double>(Clock::now() - t1).count();
}

}  // namespace piezoloop::scan
