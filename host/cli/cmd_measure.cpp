// `piezoloop [--device ADDR] measure frf [--scenario S.json [--case C]] ...`:
// the stage's frequency response from command u (V) to measured
// displacement y (µm) by a periodic multisine, or a swept sine or PRBS with
// the H1 estimate (docs/measurement.md), on a board (link/measure_session)
// or on the simulator (measure/frf_sim). Both run the core's excitation and
// share the plan and the estimate (measure/frf_plan). Every request is
// checked before anything runs (exit 2, the option and its allowed range
// named).
#include <unistd.h>

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

#include <nlohmann/json.hpp>

#include "cli/progress_bar.hpp"
#include "commands.hpp"
#include "device_common.hpp"
#include "link/mimo_measure_session.hpp"
#include "link/measure_session.hpp"
#include "format/number.hpp"
#include "lti/freqresp.hpp"
#include "measure/frf_report.hpp"
#include "measure/frf_sim.hpp"
#include "measure/coupling.hpp"
#include "measure/mimo_frf_file.hpp"
#include "measure/mimo_frf_sim.hpp"
#include "sim/plotting.hpp"
#include "sim/scenario.hpp"

namespace piezoloop::cli {
namespace {

using nlohmann::json;

struct FrfArgs {
    std::string scenario, case_name, sample, mode = "open", signal = "multisine", out, plot;
    double from_Hz = 0.0, to_Hz = 0.0, amplitude_V = 0.0, bias_V = 0.0;
    int periods = 10, transient_periods = 1;
    bool restart_stage = false;
    bool mimo = false;
    std::string output_matrix;
    std::string axis;  // a board's measured axis
};

// Where the recording came from: the JSON's "source", the plot's title.
struct Source {
    json source;
    std::string label;
    std::optional<double> setpoint_um;  // closed loop on the simulator
};

void plot_frf(const std::string& png, const std::string& label, const measure::FrfRun& r) {
    const measure::FrfEstimate& e = r.estimate;
    json mag = json::array(), ph = json::array(), sd = json::array(), coh = json::array();
    for (std::size_t i = 0; i < e.response.size(); ++i) {
        mag.push_back(design::magnitude_db(e.response[i]));
        ph.push_back(design::phase_deg(e.response[i]));
        sd.push_back(std::isfinite(e.std_db[i]) ? e.std_db[i] : 0.0);
        if (!r.coherence.empty()) coh.push_back(r.coherence[i]);
    }
    auto panel = [&](const std::string& title, const std::string& ylabel, const json& y, const std::string& yscale) {
        return json{{"title", title},
                    {"xlabel", "frequency (Hz)"},
                    {"ylabel", ylabel},
                    {"xscale", "log"},
                    {"yscale", yscale},
                    {"series", json::array({{{"label", "measured"}, {"x", e.frequency_Hz}, {"y", y}, {"style", "-"}}})}};
    };
    json spec;
    spec["title"] = label + ": measured frequency response u (V) -> y (um), " + r.plan.signal;
    spec["panels"] = json::array({panel("magnitude", "dB (um/V)", mag, "linear"), panel("phase", "deg", ph, "linear"),
                                  r.coherence.empty() ? panel("standard deviation of |G|", "dB", sd, "log")
                                                      : panel("coherence", "", coh, "linear")});
    sim::plot_spec("plot.py", spec, {std::filesystem::absolute(png).string()});
}

measure::FrfRequest frf_request(const FrfArgs& a) {
    measure::FrfRequest r;
    r.signal = a.signal;
    r.from_Hz = a.from_Hz;
    r.to_Hz = a.to_Hz;
    r.amplitude_V = a.amplitude_V;
    r.bias_V = a.bias_V;
    r.closed = a.mode == "closed";
    r.periods = a.periods;
    r.transient_periods = a.transient_periods;
    return r;
}

void write_json(const std::string& path, const json& j) {
    std::ofstream f(path);
    if (!f) throw std::runtime_error("--out: cannot write " + path);
    f << j.dump(1) << "\n";
    if (!f) throw std::runtime_error("--out: cannot write " + path);
}

// An n x n output matrix from a JSON file with "output_matrix" (rows), as
// `analyze coupling` prints it.
Eigen::MatrixXd read_output_matrix(const std::string& path) {
    std::ifstream f(path);
    if (!f) throw std::invalid_argument("--output-matrix: cannot read " + path);
    json j;
    try {
        j = json::parse(f);
    } catch (const json::exception&) {
        throw std::invalid_argument("--output-matrix: " + path + " is not JSON");
    }
    if (!j.is_object() || !j.contains("output_matrix") || !j["output_matrix"].is_array() || j["output_matrix"].empty())
        throw std::invalid_argument("--output-matrix: " + path + " has no \"output_matrix\" (rows of numbers, as `analyze coupling` prints)");
    const json& rows = j["output_matrix"];
    const auto n = static_cast<Eigen::Index>(rows.size());
    Eigen::MatrixXd m(n, n);
    for (Eigen::Index i = 0; i < n; ++i) {
        const json& row = rows[static_cast<std::size_t>(i)];
        if (!row.is_array() || static_cast<Eigen::Index>(row.size()) != n)
            throw std::invalid_argument("--output-matrix: output_matrix[" + std::to_string(i) + "]: must hold " +
                                        std::to_string(n) + " numbers (a square matrix)");
        for (Eigen::Index k = 0; k < n; ++k) {
            const json& v = row[static_cast<std::size_t>(k)];
            if (!v.is_number())
                throw std::invalid_argument("--output-matrix: output_matrix[" + std::to_string(i) + "][" +
                                            std::to_string(k) + "]: must be a number");
            m(i, k) = v.get<double>();
        }
    }
    return m;
}

// --mimo: the n x n response of a scenario's coupled axes (simulator only).
// The coupling pairs of a measured n x n response, named by the axes.
json coupling_pairs(const measure::MimoFrfEstimate& e, const std::vector<std::string>& names) {
    const measure::Coupling c = measure::coupling(e.frequency_Hz, e.response, std::nullopt);
    json pairs = json::array();
    for (const measure::CouplingPair& p : c.pairs)
        pairs.push_back({{"pair", names[static_cast<std::size_t>(p.output)] + "<-" + names[static_cast<std::size_t>(p.input)]},
                         {"low_frequency_db", std::isfinite(p.low_frequency_db) ? json(p.low_frequency_db) : json(nullptr)},
                         {"max_db", std::isfinite(p.max_db) ? json(p.max_db) : json(nullptr)},
                         {"max_Hz", p.max_Hz}});
    return pairs;
}

// --mimo on a board of axes: one axis at a time (link/mimo_measure_session).
int run_frf_mimo_board(const FrfArgs& a) {
    if (!a.output_matrix.empty())
        throw std::invalid_argument("--output-matrix: the board's own output_matrix group applies (`piezoloop set "
                                    "output_matrix`)");
    if (a.restart_stage) throw std::invalid_argument("--restart-stage: not with --mimo on a board");
    hostlink::Client c = open_device(5000);
    const measure::MimoFrfRequest r = hostlink::board_mimo_request(c, a.from_Hz, a.to_Hz, a.amplitude_V, a.bias_V,
                                                                   a.periods, a.transient_periods);
    const int n = r.inputs;
    ProgressBar bar("measure frf --mimo");
    const StopSignals stop_signals;
    hostlink::MeasureOptions o;
    o.progress = [&](double f) { bar.update(f); };
    o.stop_requested = [] { return StopSignals::requested(); };
    const hostlink::DeviceMimoFrfRun run =
        interruptible("measure frf --mimo", [&] { return hostlink::run_mimo_frf_device(c, r, o); });
    bar.done();
    measure::write_mimo_frf(a.out, run.estimate);
    json out = hostlink::board_mimo_report(c, run);
    out["out"] = a.out;
    out["coupling"] = coupling_pairs(run.estimate, out["axes"].get<std::vector<std::string>>());
    std::cout << out.dump(1) << "\n";
    std::cerr << "measure frf --mimo: " << run.estimate.frequency_Hz.size() << " lines x " << n << " x " << n
              << " on the board, one axis at a time, in " << format::significant(run.wall_s, 3) << " s wall\n";
    return 0;
}

int run_frf_mimo(const FrfArgs& a) {
    if (a.scenario.empty() && !device_address().empty()) {
        if (!a.case_name.empty() || !a.sample.empty() || a.mode != "open" || a.signal != "multisine" || !a.plot.empty() ||
            !a.axis.empty())
            throw std::invalid_argument(!a.axis.empty() ? "--axis: not with --mimo (it measures every axis)"
                                        : a.mode != "open" ? "--mode: --mimo measures open loop only"
                                        : a.signal != "multisine" ? "--signal: --mimo uses multisines only"
                                        : !a.plot.empty() ? "--plot: not with --mimo (analyze coupling reads the CSV)"
                                                          : "--case, --sample: the simulator's (--scenario)");
        return run_frf_mimo_board(a);
    }
    if (!device_address().empty() || a.scenario.empty())
        throw std::invalid_argument("--mimo: a scenario's stage of coupled axes (--scenario, simulator) or the board of "
                                    "axes given by --device, not both");
    if (!a.case_name.empty()) throw std::invalid_argument("--case: not with --mimo (open loop on the stage alone)");
    if (!a.axis.empty()) throw std::invalid_argument("--axis: not with --mimo (it measures every axis)");
    if (!a.sample.empty()) throw std::invalid_argument("--sample: not with --mimo (the stage is driven directly)");
    if (a.mode != "open") throw std::invalid_argument("--mode: --mimo measures open loop only");
    if (a.signal != "multisine") throw std::invalid_argument("--signal: --mimo uses orthogonal multisines only");
    if (!a.plot.empty()) throw std::invalid_argument("--plot: not with --mimo (analyze coupling reads the CSV)");
    if (a.restart_stage) throw std::invalid_argument("--restart-stage: only on a board (--device)");
    const sim::Scenario s = sim::load_scenario(a.scenario);
    const measure::MimoFrfRequest r =
        measure::mimo_request(s, a.from_Hz, a.to_Hz, a.amplitude_V, {a.bias_V}, a.periods, a.transient_periods);
    (void)measure::plan_mimo_frf(r);  // refuses before anything runs (and before --out is touched)
    std::optional<Eigen::MatrixXd> d;
    if (!a.output_matrix.empty()) d = read_output_matrix(a.output_matrix);
    const auto t0 = std::chrono::steady_clock::now();
    bool shown = false;
    const measure::MimoFrfSimRun run = measure::run_mimo_frf_sim(s, r, d, [&](double f) { progress_bar(f, t0, shown); });
    const double total_s = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
    measure::write_mimo_frf(a.out, run.estimate);
    std::vector<std::string> names;
    for (const sim::AxisSpec& ax : s.axes) names.push_back(ax.name);
    const json pairs = coupling_pairs(run.estimate, names);
    const json axes = names;
    const double simulated_s = static_cast<double>(run.plan.block_samples) * run.plan.inputs / s.rate_Hz;
    json out = measure::mimo_frf_summary(run.estimate);
    out["out"] = a.out;
    out["axes"] = axes;
    out["source"] = {{"kind", "simulator"}, {"scenario", s.name}};
    out["output_matrix"] = d ? "given" : "identity";
    out["coupling"] = pairs;
    out["clamped_samples"] = run.clamped_samples;
    out["slew_limited_samples"] = run.slew_limited_samples;
    out["simulated_s"] = simulated_s;
    out["wall_s"] = total_s;
    out["log_hash"] = format::hex64(run.log_hash);
    std::cout << out.dump(1) << "\n";
    std::cerr << "measure frf --mimo: " << run.estimate.frequency_Hz.size() << " lines x " << run.plan.inputs << " x "
              << run.plan.inputs << ", " << format::significant(simulated_s, 4) << " s simulated in "
              << format::significant(total_s, 3) << " s wall\n";
    return 0;
}

int run_frf(const FrfArgs& a) {
    if (a.mimo) return run_frf_mimo(a);
    const bool given_board = measure_on_board(a.scenario, a.case_name, a.restart_stage);
    if (!a.axis.empty() && !given_board) throw std::invalid_argument("--axis: only on a board (--device)");
    if (!a.output_matrix.empty()) throw std::invalid_argument("--output-matrix: only with --mimo");
    const bool on_board = given_board;
    if (on_board && !a.sample.empty()) throw std::invalid_argument("--sample: only with --scenario (a board has its own)");
    const measure::FrfRequest r = frf_request(a);
    const auto t0 = std::chrono::steady_clock::now();
    measure::FrfRun run;
    Source src;
    double rate_Hz = 0.0;
    json recording;
    if (on_board) {
        hostlink::Client c = open_device(5000);
        const auto axis = static_cast<uint8_t>(resolve_axis(a.axis, c.axis_count(), false));
        (void)hostlink::plan_frf_device(c, r, axis);  // refuses before anything moves
        rate_Hz = c.info().loop_rate_Hz;
        ProgressBar bar("measure frf");
        const StopSignals stop_signals;
        hostlink::MeasureOptions o;
        o.restart_stage = a.restart_stage;
        o.axis = axis;
        o.progress = [&](double f) { bar.update(f); };
        o.stop_requested = [] { return StopSignals::requested(); };
        hostlink::DeviceFrfRun d = interruptible("measure frf", [&] { return hostlink::run_frf_device(c, r, o); });
        bar.done();
        run = std::move(d.run);
        src.source = {{"kind", "board"}, {"device", c.address()}, {"board", c.info().board.data()}};
        if (c.axis_count() > 1) src.source["axis"] = a.axis;
        src.label = std::string(c.info().board.data()) + " (" + c.address() + ")";
        recording = hostlink::recording_summary(d.record);
    } else {
        const sim::Scenario s = sim::load_scenario(a.scenario);
        sim::require_single_axis(s, "measure frf without --mimo");
        sim::CaseSpec storage;
        const sim::CaseSpec* c = measured_case(s, a.case_name, a.sample, storage);
        if (r.closed && a.case_name.empty()) throw std::invalid_argument("--case: closed loop needs the case whose controller closes it");
        (void)measure::plan_frf(s, r);  // refuses before anything runs (and before --out is touched)
        bool shown = false;
        run = measure::run_frf_sim(s, c, r, [&](double f) { progress_bar(f, t0, shown); });
        rate_Hz = s.rate_Hz;
        src.source = {{"kind", "simulator"}, {"scenario", s.name}, {"case", a.case_name}};
        src.label = s.name;
        if (r.closed) src.setpoint_um = a.bias_V * s.command_um_per_V();
    }
    const double total_s = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
    json out = measure::frf_report(r, run, src.source, src.setpoint_um);
    if (!recording.is_null()) out["recording"] = recording;
    write_json(a.out, out);
    if (!a.plot.empty()) plot_frf(a.plot, src.label, run);
    const double measured_s = static_cast<double>(run.plan.ticks) / rate_Hz;
    std::cout << json{{"out", a.out},
                      {"lines", run.estimate.frequency_Hz.size()},
                      {"from_Hz", run.estimate.frequency_Hz.front()},
                      {"to_Hz", run.estimate.frequency_Hz.back()},
                      {"line_spacing_Hz", run.estimate.frequency_Hz.size() > 1
                                              ? run.estimate.frequency_Hz[1] - run.estimate.frequency_Hz[0]
                                              : 0.0},
                      {on_board ? "device_s" : "simulated_s", measured_s},
                      {"wall_s", total_s},
                      {"clipped_samples", run.clipped_samples},
                      {"log_hash", format::hex64(run.log_hash)},
                      {"warnings", run.warnings}}
                     .dump(1)
              << "\n";
    for (const std::string& w : run.warnings) std::cerr << "measure frf: warning: " << w << "\n";
    std::cerr << "measure frf: " << run.estimate.frequency_Hz.size() << " lines, " << format::significant(measured_s, 4)
              << (on_board ? " s on the board in " : " s simulated in ") << format::significant(total_s, 3)
              << " s wall\n";
    return 0;
}

void add_measure(CLI::App& app) {
    CLI::App* measure = app.add_subcommand(
        "measure", "Measure a stage on a board (--device) or on the simulator (--scenario): frequency response, step "
                   "response, hysteresis loops");
    measure->require_subcommand(1);
    auto a = std::make_shared<FrfArgs>();
    CLI::App* cmd = measure->add_subcommand(
        "frf", "Frequency response u (V) -> y (um): periodic multisine with Schroeder phases, or swept sine / PRBS "
        "with H1 and coherence (docs/measurement.md)");
    cmd->add_option("--scenario", a->scenario, "scenario file (configs/*.json): measure the simulated stage instead of a board")
        ->check(CLI::ExistingFile);
    cmd->add_option("--case", a->case_name, "case: its controller (closed loop) and any hysteresis override");
    cmd->add_option("--sample", a->sample, "simulator: core sample type (default: the case's, else float)")
        ->check(CLI::IsMember({"float", "q31"}));
    cmd->add_option("--from-hz", a->from_Hz, "lowest frequency; also the line spacing (period = rate / F1)")
        ->required();
    cmd->add_option("--to-hz", a->to_Hz, "highest frequency, below rate / 2")->required();
    cmd->add_option("--amplitude-v", a->amplitude_V, "peak of the excitation at the command (V)")->required();
    cmd->add_option("--bias-v", a->bias_V, "open loop: the command the excitation is centred on (V); closed loop on "
                                           "the simulator: the setpoint, as the displacement this command gives at the "
                                           "mean slope (a board holds its own setpoint)");
    cmd->add_option("--mode", a->mode, "open: no controller; closed: the case's (simulator) or the board's controller runs")
        ->check(CLI::IsMember({"open", "closed"}));
    cmd->add_option("--signal", a->signal, "excitation: multisine (periodic estimate), sweep or prbs (H1, Welch, coherence)")->check(CLI::IsMember({"multisine", "sweep", "prbs"}));
    cmd->add_option("--periods", a->periods, "measured periods, averaged (>= 2 for the variance)");
    cmd->add_option("--transient-periods", a->transient_periods, "periods run first and discarded");
    cmd->add_option("--out", a->out, "the response as JSON (with --mimo: the n x n response as CSV, read by "
                                     "`analyze coupling`)")->required();
    cmd->add_flag("--mimo", a->mimo,
                  "a scenario's stage of coupled axes: the n x n response from orthogonal multisines on every axis at "
                  "once (simulator, open loop; --bias-v applies to every axis)");
    cmd->add_option("--output-matrix", a->output_matrix,
                    "with --mimo: the decoupling matrix between axis commands and channels, a JSON file with "
                    "\"output_matrix\" as `analyze coupling` prints it (default: the identity)");
    cmd->add_option("--plot", a->plot, "magnitude, phase and standard deviation as a PNG (tools/plot.py)");
    cmd->add_option("--axis", a->axis,
                    "a board of axes: x | y | z, the measured axis (default: the only axis; required on a multi-axis "
                    "board); the others hold with their own controllers");
    cmd->add_flag("--restart-stage", a->restart_stage,
                  "emulated board: its stage restarts at rest with the excitation (the recording then equals the "
                  "simulator's: same log hash)");
    cmd->callback([a] { guarded([&] { return run_frf(*a); }); });
}

const bool registered_measure = register_command(45, add_measure);

}  // namespace
}  // namespace piezoloop::cli
