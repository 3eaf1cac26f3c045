// `piezoloop measure step` and `piezoloop measure loops` on a board (--device)
// or the simulator (--scenario) (issue 16, docs/measurement.md): a step of
// chosen size in open loop
// (command, V) or closed loop (reference, um) with its overshoot, rise and
// settling time; slow open-loop triangles (or sines) of several amplitudes,
// written as the CSV `identify pi` (columns u, y) and `identify dahl`
// (columns v, x) read, with the hysteresis of each loop. The runs are in
// host/measure/step_loops_sim and host/link/measure_session, the plans and
// the analysis they share in host/measure/step_loops_plan.
// Every request is checked before anything runs or any file is written
// (exit 2, the option and its allowed range named).
#include <unistd.h>

#include <chrono>
#include <cmath>
#include <cstdio>
#include <fstream>
#include <iostream>
#include <memory>
#include <optional>
#include <stdexcept>
#include <string>

#include <nlohmann/json.hpp>

#include "analysis/loop_report.hpp"
#include "cli/progress_bar.hpp"
#include "commands.hpp"
#include "device_common.hpp"
#include "format/number.hpp"
#include "link/measure_session.hpp"
#include "measure/step_loops_sim.hpp"
#include "sim/scenario.hpp"

namespace piezoloop::cli {
namespace {

using nlohmann::json;

void write_text(const std::string& option, const std::string& path, const std::string& text) {
    std::ofstream f(path);
    if (!f) throw std::runtime_error(option + ": cannot write " + path);
    f << text;
    if (!f) throw std::runtime_error(option + ": cannot write " + path);
}

// The stage a measurement runs on: a board (--device) or the simulator
// (--scenario, with an optional case).
struct Target {
    std::optional<hostlink::Client> board;
    std::optional<sim::Scenario> scenario;
    sim::CaseSpec case_storage;
    const sim::CaseSpec* case_spec = nullptr;
    measure::MeasureBounds bounds;
    json source;

    Target(const std::string& scenario_path, const std::string& case_name, const std::string& sample,
           bool restart_stage) {
        if (measure_on_board(scenario_path, case_name, restart_stage)) {
            if (!sample.empty()) throw std::invalid_argument("--sample: only with --scenario (a board has its own)");
            board.emplace(open_device(5000));
            bounds = hostlink::board_bounds(*board);
            source = {{"kind", "board"}, {"device", board->address()}, {"board", board->info().board.data()},
                      {"rate_Hz", bounds.rate_Hz}};
        } else {
            scenario = sim::load_scenario(scenario_path);
            case_spec = measured_case(*scenario, case_name, sample, case_storage);
            bounds = measure::scenario_bounds(*scenario);
            source = {{"kind", "simulator"}, {"scenario", scenario->name}, {"case", case_name}, {"rate_Hz", bounds.rate_Hz}};
        }
    }
};

// Progress on stderr and Ctrl-C for a board; the simulator's bar otherwise.
struct Progress {
    explicit Progress(const char* label) : bar(label) {}
    hostlink::MeasureOptions board_options(bool restart_stage) {
        hostlink::MeasureOptions o;
        o.restart_stage = restart_stage;
        o.progress = [this](double f) { bar.update(f); };
        o.stop_requested = [] { return StopSignals::requested(); };
        return o;
    }
    std::function<void(double)> sim_progress() {
        return [this](double f) { progress_bar(f, t0, shown); };
    }
    ProgressBar bar;
    StopSignals stop_signals;
    std::chrono::steady_clock::time_point t0 = std::chrono::steady_clock::now();
    bool shown = false;
};

// --scenario (simulator) or the global --device (board), and the emulated
// board's restart.
void add_source_options(CLI::App* cmd, std::string& scenario, std::string& sample, bool& restart_stage) {
    cmd->add_option("--scenario", scenario, "scenario file (configs/*.json): measure the simulated stage instead of a board")
        ->check(CLI::ExistingFile);
    cmd->add_option("--sample", sample, "simulator: core sample type (default: the case's, else float)")
        ->check(CLI::IsMember({"float", "q31"}));
    cmd->add_flag("--restart-stage", restart_stage,
                  "emulated board: its stage restarts at rest with the measurement (as the simulator starts)");
}

// ---------------------------------------------------------------- step

struct StepArgs {
    std::string scenario, case_name, sample, mode, out, csv;
    // Optional, not NaN-defaulted: a NaN given on the command line must be refused, not taken as absent.
    std::optional<double> step_um, step_V, from_um, bias_V;
    double duration_s = 0.1;
    bool restart_stage = false;
};

measure::StepRequest step_request(const StepArgs& a, Target& t) {
    const bool has_um = a.step_um.has_value(), has_v = a.step_V.has_value();
    if (has_um == has_v) throw std::invalid_argument("--step-um: give exactly one of --step-um (closed loop) and --step-v (open loop)");
    const std::string mode = a.mode.empty() ? (has_um ? "closed" : "open") : a.mode;
    measure::StepRequest r;
    r.closed = mode == "closed";
    if (r.closed && !has_um) throw std::invalid_argument("--step-v: closed loop steps the reference: give --step-um");
    if (!r.closed && !has_v) throw std::invalid_argument("--step-um: open loop steps the command: give --step-v");
    if (r.closed && a.bias_V) throw std::invalid_argument("--bias-v: open loop only; closed loop starts from --from-um");
    if (!r.closed && a.from_um) throw std::invalid_argument("--from-um: closed loop only; open loop starts from --bias-v");
    r.step = r.closed ? *a.step_um : *a.step_V;
    r.duration_s = a.duration_s;
    if (r.closed && a.from_um) {
        r.from = *a.from_um;
    } else if (r.closed && t.board) {
        r.from = t.board->status().r_um;  // the setpoint the board holds
    } else if (r.closed) {
        // 10 % into the range the loop can hold, clear of the ADC's end.
        const measure::RangeUm& range = t.bounds.closed_range;
        r.from = range.min_um + 0.1 * (range.max_um - range.min_um);
    } else {
        r.from = a.bias_V ? *a.bias_V : std::max(0.0, static_cast<double>(t.bounds.limits.u_min_V));
    }
    return r;
}

int run_step(const StepArgs& a) {
    Target t(a.scenario, a.case_name, a.sample, a.restart_stage);
    const measure::StepRequest r = step_request(a, t);
    if (r.closed && t.scenario && a.case_name.empty())
        throw std::invalid_argument("--case: closed loop needs the case whose controller closes it");
    (void)measure::plan_step(t.bounds, r);  // refuses before anything runs (and before --out is touched)
    Progress p("measure step");
    const measure::StepRun run = t.board ? hostlink::run_step_device(*t.board, r, p.board_options(a.restart_stage))
                                         : measure::run_step_sim(*t.scenario, t.case_spec, r, p.sim_progress());
    p.bar.done();
    const measure::StepFigures& f = run.figures;
    json out;
    out["mode"] = r.closed ? "closed" : "open";
    out["step"] = {{"size", r.step}, {"from", r.from}, {"unit", r.closed ? "um (reference)" : "V (command)"}};
    out["initial_um"] = f.initial;
    out["final_value_um"] = f.final_value;
    out["overshoot_pct"] = f.overshoot_pct;
    out["peak_um"] = f.peak;
    out["peak_time_s"] = f.peak_time_s;
    out["rise_time_s"] = design::report_number(f.rise_time_s);
    out["settling_time_s"] = design::report_number(f.settling_time_s);
    out["settled"] = f.settled;
    out["definitions"] = {
        {"initial_um", "mean of the recorded samples before the step"},
        {"final_value_um", "mean of the last 10 % of the samples after the step"},
        {"overshoot_pct", "(peak - final) / (final - initial) x 100, 0 if no overshoot"},
        {"rise_time_s", "10 % to 90 % of final - initial, first crossings, interpolated"},
        {"settling_time_s", "after the step, the time from which y stays within 2 % of final - initial of final"}};
    out["time_s"] = run.time_s;
    out["reference_um"] = run.r_um;
    out["command_V"] = run.u_V;
    out["response_um"] = run.y_um;
    out["units"] = {{"time", "s, 0 at the tick the step is applied"},
                    {"reference", "um"},
                    {"command", "V at the amplifier input, after the limiter"},
                    {"response", "um, the sensor's reading / its gain, as the controller used it"}};
    out["source"] = t.source;
    out["clipped_samples"] = run.clipped_samples;
    out["limiter_trip"] = run.trip;
    out["warnings"] = run.warnings;
    out["log_hash"] = format::hex64(run.log_hash);
    out["wall_s"] = run.wall_s;
    write_text("--out", a.out, out.dump(1) + "\n");
    if (!a.csv.empty()) {
        std::string text = "t,r,u,y\n";
        for (std::size_t i = 0; i < run.y_um.size(); ++i)
            text += format::significant(run.time_s[i], 9) + "," + format::significant(run.r_um[i], 9) + "," +
                    format::significant(run.u_V[i], 9) + "," + format::significant(run.y_um[i], 9) + "\n";
        write_text("--csv", a.csv, text);
    }
    json summary = out;
    for (const char* k : {"time_s", "reference_um", "command_V", "response_um", "definitions", "units"}) summary.erase(k);
    summary["out"] = a.out;
    std::cout << summary.dump(1) << "\n";
    std::cerr << "measure step: overshoot " << format::significant(f.overshoot_pct, 3) << " %, rise "
              << format::significant(f.rise_time_s * 1e3, 3) << " ms, settling "
              << format::significant(f.settling_time_s * 1e3, 3) << " ms\n";
    return 0;
}

void add_step(CLI::App* measure) {
    auto a = std::make_shared<StepArgs>();
    CLI::App* cmd = measure->add_subcommand(
        "step", "Step response: open loop (command step, V) or closed loop (reference step, um); overshoot, "
                "10-90 % rise and 2 % settling time (docs/measurement.md)");
    add_source_options(cmd, a->scenario, a->sample, a->restart_stage);
    cmd->add_option("--case", a->case_name, "case: its controller (closed loop) and any hysteresis override");
    cmd->add_option("--step-um", a->step_um, "closed loop: reference step (um)");
    cmd->add_option("--step-v", a->step_V, "open loop: command step (V)");
    cmd->add_option("--mode", a->mode, "open or closed (default: from the step option given)")
        ->check(CLI::IsMember({"open", "closed"}));
    cmd->add_option("--from-um", a->from_um, "closed loop: setpoint before the step (default: a board's setpoint; "
                                             "on the simulator 10 % into the range)");
    cmd->add_option("--bias-v", a->bias_V, "open loop: command before the step (default max(0, lower limit))");
    cmd->add_option("--duration-s", a->duration_s, "recorded after the step; the level before it is held as long")
        ->capture_default_str();
    cmd->add_option("--out", a->out, "figures and the response as JSON")->required();
    cmd->add_option("--csv", a->csv, "the response as CSV: t, r, u, y");
    cmd->callback([a] { guarded([&] { return run_step(*a); }); });
}

// ---------------------------------------------------------------- loops

struct LoopsArgs {
    std::string scenario, case_name, sample, out, json_out, shape = "triangle";
    std::vector<double> amplitudes_V;
    double frequency_Hz = 1.0;
    std::optional<double> base_V;
    int cycles = 2;
    bool restart_stage = false;
};

int run_loops(const LoopsArgs& a) {
    Target t(a.scenario, a.case_name, a.sample, a.restart_stage);
    measure::LoopsRequest r;
    r.amplitudes_V = a.amplitudes_V;
    r.base_V = a.base_V ? *a.base_V : std::max(0.0, static_cast<double>(t.bounds.limits.u_min_V));
    r.frequency_Hz = a.frequency_Hz;
    r.cycles = a.cycles;
    r.shape = a.shape;
    (void)measure::plan_loops(t.bounds, r);  // refuses before anything runs
    Progress p("measure loops");
    const measure::LoopsRun run = t.board ? hostlink::run_loops_device(*t.board, r, p.board_options(a.restart_stage))
                                          : measure::run_loops_sim(*t.scenario, t.case_spec, r, p.sim_progress());
    p.bar.done();
    // Columns for both identifiers' defaults: identify pi reads u, y;
    // identify dahl reads v, x; t gives the sample period.
    // Written as it is formatted: a long record would double its memory as one string.
    std::ofstream csv(a.out);
    if (!csv) throw std::runtime_error("--out: cannot write " + a.out);
    csv << "t,u,y,v,x,amplitude_V\n";
    for (std::size_t i = 0; i < run.y_um.size(); ++i) {
        const std::string u = format::significant(run.u_V[i], 9), y = format::significant(run.y_um[i], 9);
        csv << format::significant(run.time_s[i], 9) << ',' << u << ',' << y << ',' << u << ',' << y << ','
            << format::significant(run.amplitude_V[i], 9) << '\n';
    }
    if (!csv.flush()) throw std::runtime_error("--out: cannot write " + a.out);
    json loops = json::array();
    for (const measure::LoopFigures& f : run.loops)
        loops.push_back({{"amplitude_V", f.amplitude_V},
                         {"hysteresis_pct", f.hysteresis_pct >= 0 ? json(f.hysteresis_pct) : json()},
                         {"max_width_pct", f.max_width_pct >= 0 ? json(f.max_width_pct) : json()},
                         {"y_min_um", f.y_min_um},
                         {"y_max_um", f.y_max_um}});
    json out;
    out["out"] = a.out;
    out["loops"] = loops;
    out["shape"] = r.shape;
    out["base_V"] = r.base_V;
    out["frequency_Hz"] = r.frequency_Hz;
    out["cycles"] = r.cycles;
    out["samples"] = run.y_um.size();
    out["definitions"] = {
        {"hysteresis_pct", "last cycle of the amplitude: |y_up - y_down| at the input's midpoint / (y_max - y_min) "
                           "x 100 (Ahmad2020 eq. 25-26, as piezoloop sim reports it)"},
        {"max_width_pct", "last cycle: the widest |y_up - y_down| at a common input / (y_max - y_min) x 100"},
        {"columns", "t (s), u = v (command, V, after the limiter), y = x (displacement read at the next tick, um), "
                    "amplitude_V (the loop the sample belongs to)"}};
    out["source"] = t.source;
    out["clipped_samples"] = run.clipped_samples;
    out["limiter_trip"] = run.trip;
    out["warnings"] = run.warnings;
    out["log_hash"] = run.log_hash != 0 ? json(format::hex64(run.log_hash)) : json();
    out["wall_s"] = run.wall_s;
    if (!a.json_out.empty()) write_text("--json", a.json_out, out.dump(1) + "\n");
    json summary = out;
    summary.erase("definitions");
    std::cout << summary.dump(1) << "\n";
    std::cerr << "measure loops: " << run.loops.size() << " amplitudes, " << run.y_um.size() << " samples, "
              << format::significant(static_cast<double>(run.plan.ticks) / t.bounds.rate_Hz, 4)
              << (t.board ? " s on the board in " : " s simulated in ") << format::significant(run.wall_s, 3)
              << " s wall\n";
    return 0;
}

void add_loops(CLI::App* measure) {
    auto a = std::make_shared<LoopsArgs>();
    CLI::App* cmd = measure->add_subcommand(
        "loops", "Open-loop hysteresis loops of several amplitudes, as the CSV identify pi / identify dahl read, "
                 "and the hysteresis of each (docs/measurement.md)");
    add_source_options(cmd, a->scenario, a->sample, a->restart_stage);
    cmd->add_option("--case", a->case_name, "case: its hysteresis override and sample type");
    cmd->add_option("--amplitudes-v", a->amplitudes_V, "peak-to-peak command of each loop above the base, V (a,b,...)")
        ->required()
        ->delimiter(',');
    cmd->add_option("--bias-v", a->base_V, "command the loops start from and return to (default max(0, lower limit))");
    cmd->add_option("--frequency-hz", a->frequency_Hz, "cycles per second")->capture_default_str();
    cmd->add_option("--cycles", a->cycles, "cycles per amplitude; the last is measured")->capture_default_str();
    cmd->add_option("--shape", a->shape, "triangle or sine (1 - cos, from the base)")
        ->check(CLI::IsMember({"triangle", "sine"}))
        ->capture_default_str();
    cmd->add_option("--out", a->out, "the loops as CSV: t, u, y, v, x, amplitude_V")->required();
    cmd->add_option("--json", a->json_out, "the summary with the hysteresis per amplitude as JSON");
    cmd->callback([a] { guarded([&] { return run_loops(*a); }); });
}

// Added after `measure` (order 45, cmd_measure.cpp) to the same subcommand.
void add_step_loops(CLI::App& app) {
    CLI::App* measure = app.get_subcommand("measure");
    add_step(measure);
    add_loops(measure);
}

const bool registered = register_command(46, add_step_loops);

}  // namespace
}  // namespace piezoloop::cli
