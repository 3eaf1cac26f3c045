// `piezoloop scan`: a frame (or a few) scanned on the simulator's stage of
// coupled axes, or on a board of two or three axes (--device), over an
// emulated sample (docs/scan.md): the per-tick record as CSV, the figures as
// JSON (also on stdout), the images at commanded and at measured positions
// and the error maps as PNG (tools/plot_image.py). Ctrl-C stops the scan,
// writes what arrived marked incomplete, and exits 4.
#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <iostream>
#include <memory>
#include <optional>
#include <stdexcept>
#include <string>
#include <tuple>

#include <nlohmann/json.hpp>

#include "commands.hpp"
#include "device_common.hpp"
#include "link/scan_session.hpp"
#include "progress_bar.hpp"
#include "scan/scan_case.hpp"
#include "scan/scan_csv.hpp"
#include "sim/plotting.hpp"
#include "sim/scenario.hpp"

namespace piezoloop::cli {
namespace {

struct ScanArgs {
    std::string scenario;
    std::string case_name;
    std::string pattern = "raster";
    std::string size = "20x20";
    std::string pixels = "256x256";
    double line_rate_Hz = 50.0;
    double retrace_speed = 1.0;
    int frames = 1;
    std::string sample = "grating:pitch=2,height_nm=50";
    std::string centre;
    std::string out;
    bool restart_stage = false;  // board: the emulated stage and the loop from rest
    bool rc_period_from_scan = false;  // board: x's and y's RC period set to the scan's
    bool board_start = false;    // simulator: start as a board's StartScan with --restart-stage does
    std::string sample_type;     // simulator: float | q31 (default: the case's)
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

nlohmann::json image_spec(const scan::ScanImageSpec& im, const std::filesystem::path& dir) {
    nlohmann::json j = scan::image_json(im);
    j["out"] = (dir / (im.file_stem + ".png")).string();
    return j;
}

// The plan, the run and its figures: on the simulator, or on the board.
struct ScanDone {
    scan::ScanPlan plan;
    scan::ScanOutcome outcome;
    double rate_Hz = 0.0;
    std::string incomplete_why;  // "" when complete
};

scan::ScanRequest request_of(const ScanArgs& a) {
    scan::ScanRequest req;
    req.case_name = a.case_name;
    req.pattern = a.pattern;
    std::tie(req.size_x_um, req.size_y_um) = pair_of("--size-um", a.size, 'x', "WxH in um, e.g. 20x20");
    const auto [px, py] = pair_of("--pixels", a.pixels, 'x', "NXxNY, e.g. 256x256");
    if (px != std::floor(px) || py != std::floor(py) || px < 2 || py < 2 || px > 4096 || py > 4096)
        bad("--pixels", "each count must be a whole number in [2, 4096]");
    req.pixels_x = static_cast<int>(px);
    req.pixels_y = static_cast<int>(py);
    req.line_rate_Hz = a.line_rate_Hz;
    req.retrace_speed = a.retrace_speed;
    req.frames = a.frames;
    req.sample = a.sample;
    if (!a.centre.empty()) req.centre_um = pair_of("--centre-um", a.centre, ',', "X,Y in um, e.g. 50,50");
    return req;
}

ScanDone scan_simulator(const ScanArgs& a, const std::function<void(uint64_t, uint64_t)>& progress) {
    if (a.restart_stage) bad("--restart-stage", "a board's option (give --device)");
    if (a.rc_period_from_scan)
        bad("--rc-period-from-scan", "a board's option (the simulator sets a case's \"auto\" period from the scan)");
    sim::Scenario s = sim::load_scenario(a.scenario);
    ScanDone d;
    d.plan = scan::plan_scan(s, request_of(a), scan::option_name);
    if (!a.sample_type.empty()) {
        if (a.sample_type != "float" && a.sample_type != "q31") bad("--sample-type", "must be float or q31");
        // The case's core in the sample type asked for (as `sim --sample`).
        sim::CaseSpec storage;
        const sim::CaseSpec c = *measured_case(s, d.plan.case_name, a.sample_type, storage);
        for (sim::CaseSpec& k : s.cases)
            if (k.name == c.name) k = c;
    }
    d.rate_Hz = s.setup.rate_Hz;
    d.outcome = scan::run_scan_case(s, d.plan, [] { return StopSignals::requested(); }, progress, a.board_start);
    if (!d.outcome.run.complete) d.incomplete_why = "stopped before the end (Ctrl-C or SIGTERM)";
    return d;
}

// On a board: it runs the controllers it holds; the scenario, when given,
// is the stage it drives (its travel).
ScanDone scan_board(const ScanArgs& a, const std::function<void(uint64_t, uint64_t)>& progress) {
    if (!a.case_name.empty()) bad("--case", "the simulator's option: a board runs the controllers it holds (set --scenario)");
    if (a.board_start) bad("--board-start", "the simulator's option (a board starts with --restart-stage)");
    if (!a.sample_type.empty()) bad("--sample-type", "the simulator's option (a board runs its own core)");
    hostlink::Client c = open_device();
    std::optional<sim::Scenario> stage;
    if (!a.scenario.empty()) stage = sim::load_scenario(a.scenario);
    hostlink::BoardScanOptions o;
    o.restart_stage = a.restart_stage;
    o.rc_period_from_scan = a.rc_period_from_scan;
    o.stop_requested = [] { return StopSignals::requested(); };
    o.progress = progress;
    hostlink::BoardScan b = hostlink::scan_on_board(c, request_of(a), stage ? &*stage : nullptr, scan::option_name, o);
    if (b.outcome.figures.contains("rc"))
        for (const auto& note : b.outcome.figures["rc"]) std::fprintf(stderr, "scan: %s\n", note.get<std::string>().c_str());
    ScanDone d;
    d.plan = std::move(b.plan);
    d.outcome = std::move(b.outcome);
    d.rate_Hz = b.rate_Hz;
    d.incomplete_why = b.problems;
    return d;
}

int run(const ScanArgs& a) {
    const bool board = !device_address().empty();
    if (!board && a.scenario.empty()) bad("--scenario", "required (or --device ADDR before `scan` for a board)");
    const std::filesystem::path dir(a.out);
    const StopSignals stop_signals;
    const auto t0 = std::chrono::steady_clock::now();
    bool shown = false;
    auto progress = [&](uint64_t k, uint64_t total) {
        progress_bar(total ? std::min(1.0, static_cast<double>(k) / static_cast<double>(total)) : 1.0, t0, shown);
    };
    const ScanDone d = board ? scan_board(a, progress) : scan_simulator(a, progress);
    const scan::ScanPlan& plan = d.plan;
    const scan::ScanOutcome& r = d.outcome;
    std::filesystem::create_directories(dir);
    scan::write_scan_csv(dir / "scan.csv", r.run.ticks);
    nlohmann::json j = r.figures;
    j["csv"] = "scan.csv: one row a tick from the scan's first tick (after the approach)";
    {
        std::ofstream f(dir / "metrics.json");
        f << j.dump(1) << "\n";
        if (!f) throw std::runtime_error((dir / "metrics.json").string() + ": cannot be written");
    }
    if (!r.images.empty()) {
        nlohmann::json images = nlohmann::json::array();
        for (const scan::ScanImageSpec& im : r.images) images.push_back(image_spec(im, dir));
        sim::plot_spec("plot_image.py", {{"images", images}});
    }
    std::cout << j.dump(1) << "\n";
    const std::size_t ticks = j["ticks"], pixels = j["pixels"];
    const double stage_s = static_cast<double>(ticks) / d.rate_Hz;
    std::fprintf(stderr,
                 "scan: %s, %zu ticks (%.3f s of stage time) %s in %.3f s (%.2fx real time), %zu pixels, "
                 "figures and images in %.3f s; wrote %s\n",
                 d.incomplete_why.empty() ? "complete" : "incomplete", ticks, stage_s,
                 board ? "scanned on the board" : "simulated", r.simulate_wall_s,
                 r.simulate_wall_s > 0.0 ? stage_s / r.simulate_wall_s : 0.0, pixels, r.process_wall_s, dir.c_str());
    const double run_Hz = j["line_rate_Hz"].is_number() ? j["line_rate_Hz"].get<double>() : 0.0;
    if (plan.config.pattern == ScanPattern::kRaster && std::abs(run_Hz / a.line_rate_Hz - 1.0) > 0.05)
        std::fprintf(stderr,
                     "scan: note: lines ran at %.2f Hz, not %.2f Hz: a pixel takes whole ticks of the %.0f Hz loop "
                     "(a faster --retrace-speed leaves more of a line to the trace)\n",
                     run_Hz, a.line_rate_Hz, d.rate_Hz);
    if (!d.incomplete_why.empty())
        throw LostData("scan incomplete (" + d.incomplete_why + "): what arrived is written, marked incomplete in "
                       "metrics.json");
    return 0;
}

}  // namespace

void add_scan(CLI::App& app) {
    auto a = std::make_shared<ScanArgs>();
    CLI::App* cmd = app.add_subcommand(
        "scan",
        "Scan a frame on the simulator's XY stage, or a board's (--device), over an emulated sample: images, errors "
        "and figures");
    cmd->add_option("--scenario", a->scenario,
                    "scenario of two or three axes (configs/stages/*.json); with --device, the stage the board drives "
                    "(its travel)")
        ->check(CLI::ExistingFile);
    cmd->add_option("--case", a->case_name, "simulator: controller case of the scenario (default: its first)");
    cmd->add_option("--sample-type", a->sample_type, "simulator: the core's sample type, float | q31 (default: the case's)");
    cmd->add_flag("--restart-stage", a->restart_stage, "board: the emulated stage and the loop start from rest");
    cmd->add_flag("--rc-period-from-scan", a->rc_period_from_scan,
                  "board: set x's and y's repetitive controllers (when enabled) to the scan's period first");
    cmd->add_flag("--board-start", a->board_start,
                  "simulator: start as a board does with --restart-stage (to compare the two tick by tick)");
    cmd->add_option("--pattern", a->pattern, "raster | spiral | lissajous | cycloid (docs/scan.md)");
    cmd->add_option("--size-um", a->size, "scan size WxH in um (spiral: diameter min(W, H)), default 20x20");
    cmd->add_option("--pixels", a->pixels, "image NXxNY (raster: pixels a line x lines), default 256x256");
    cmd->add_option("--line-rate-hz", a->line_rate_Hz, "lines per second (spiral: turns per second), default 50");
    cmd->add_option("--retrace-speed", a->retrace_speed,
                    "raster: retrace speed / trace speed, 1 to 16 (default 1: both at the same speed)");
    cmd->add_option("--frames", a->frames, "frames to scan, 1 to 1000 (default 1)");
    cmd->add_option("--sample", a->sample,
                    "grating:pitch=2,height_nm=50,duty=0.5 | step:x=50,height_nm=50 | dots:pitch=2,radius=0.5,height_nm=20");
    cmd->add_option("--centre-um", a->centre, "scan centre X,Y in um (default: the middle of each axis's travel)");
    cmd->add_option("--out", a->out, "output folder: scan.csv, metrics.json, image_*.png, error_*.png")->required();
    cmd->callback([a] { guarded([&] { return run(*a); }); });
}

namespace {
const bool registered_scan = register_command(42, add_scan);
}  // namespace

}  // namespace piezoloop::cli
