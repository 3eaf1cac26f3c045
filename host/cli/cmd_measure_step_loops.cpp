// `piezoloop measure step` and `piezoloop measure loops` on a board (--device)
// or the simulator (--scenario) (docs/measurement.md): a step of
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
#include <sstream>
#include <stdexcept>
#include <string>

#include <nlohmann/json.hpp>

#include "cli/progress_bar.hpp"
#include "commands.hpp"
#include "device_common.hpp"
#include "format/number.hpp"
#include "link/measure_session.hpp"
#include "measure/step_loops_report.hpp"
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
    uint8_t axis = 0;  // a board's measured axis

    Target(const std::string& scenario_path, const std::string& case_name, const std::string& sample,
           bool restart_stage, const std::string& axis_name) {
        if (measure_on_board(scenario_path, case_name, restart_stage)) {
            if (!sample.empty()) throw std::invalid_argument("--sample: only with --scenario (a board has its own)");
            board.emplace(open_device(5000));
            axis = static_cast<uint8_t>(resolve_axis(axis_name, board->axis_count(), false));
            bounds = hostlink::board_bounds(*board, axis);
            source = {{"kind", "board"}, {"device", board->address()}, {"board", board->info().board.data()},
                      {"rate_Hz", bounds.rate_Hz}};
            if (board->axis_count() > 1) source["axis"] = axis_name;
        } else {
            if (!axis_name.empty()) throw std::invalid_argument("--axis: only on a board (--device)");
            scenario = sim::load_scenario(scenario_path);
            sim::require_single_axis(*scenario, "measure");
            case_spec = measured_case(*scenario, case_name, sample, case_storage);
            bounds = measure::scenario_bounds(*scenario);
            source = {{"kind", "simulator"}, {"scenario", scenario->name}, {"case", case_name}, {"rate_Hz", bounds.rate_Hz}};
        }
    }
};

// Progress on stderr and Ctrl-C for a board; the simulator's bar otherwise.
struct StepLoopsProgress {
    explicit StepLoopsProgress(const char* label) : bar(label) {}
    hostlink::MeasureOptions board_options(bool restart_stage, uint8_t axis) {
        hostlink::MeasureOptions o;
        o.restart_stage = restart_stage;
        o.axis = axis;
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
void add_source_options(CLI::App* cmd, std::string& scenario, std::string& sample, bool& restart_stage,
                        std::string& axis) {
    cmd->add_option("--scenario", scenario, "scenario file (configs/*.json): measure the simulated stage instead of a board")
        ->check(CLI::ExistingFile);
    cmd->add_option("--sample", sample, "simulator: core sample type (default: the case's, else float)")
        ->check(CLI::IsMember({"float", "q31"}));
    cmd->add_flag("--restart-stage", restart_stage,
                  "emulated board: its stage restarts at rest with the measurement (as the simulator starts)");
    cmd->add_option("--axis", axis,
                    "a board of axes: x | y | z, the measured axis (default: the only axis; required on a multi-axis "
                    "board); the others hold with their own controllers");
}

// ---------------------------------------------------------------- step

struct StepArgs {
    std::string scenario, case_name, sample, mode, out, csv, axis;
    // Optional, not NaN-defaulted: a NaN given on the command line must be refused, not taken as absent.
    std::optional<double> step_um, step_V, from_um, bias_V;
    double duration_s = 0.1;
    bool restart_stage = false;
};

measure::StepRequest step_request(const StepArgs& a, Target& t) {
    measure::StepInput o;
    o.step_um = a.step_um;
    o.step_V = a.step_V;
    o.from_um = a.from_um;
    o.bias_V = a.bias_V;
    o.mode = a.mode;
    o.duration_s = a.duration_s;
    std::optional<double> board_setpoint_um;
    if (t.board && !a.from_um) board_setpoint_um = t.board->status().r_um;  // a closed step starts where the board holds
    return measure::step_request(o, t.bounds, board_setpoint_um);
}

int run_step(const StepArgs& a) {
    Target t(a.scenario, a.case_name, a.sample, a.restart_stage, a.axis);
    const measure::StepRequest r = step_request(a, t);
    if (r.closed && t.scenario && a.case_name.empty())
        throw std::invalid_argument("--case: closed loop needs the case whose controller closes it");
    (void)measure::plan_step(t.bounds, r);  // refuses before anything runs (and before --out is touched)
    StepLoopsProgress p("measure step");
    const measure::StepRun run = t.board ? interruptible("measure step", [&] {
        return hostlink::run_step_device(*t.board, r, p.board_options(a.restart_stage, t.axis));
    })
                                         : measure::run_step_sim(*t.scenario, t.case_spec, r, p.sim_progress());
    p.bar.done();
    const measure::StepFigures& f = run.figures;
    const json out = measure::step_report(r, run, t.source);
    write_text("--out", a.out, out.dump(1) + "\n");
    if (!a.csv.empty()) {
        std::ostringstream text;
        measure::write_step_csv(text, run);
        write_text("--csv", a.csv, text.str());
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
    add_source_options(cmd, a->scenario, a->sample, a->restart_stage, a->axis);
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
    std::string scenario, case_name, sample, out, json_out, shape = "triangle", axis;
    std::vector<double> amplitudes_V;
    double frequency_Hz = 1.0;
    std::optional<double> base_V;
    int cycles = 2;
    bool restart_stage = false;
};

int run_loops(const LoopsArgs& a) {
    Target t(a.scenario, a.case_name, a.sample, a.restart_stage, a.axis);
    const measure::LoopsRequest r =
        measure::loops_request(a.amplitudes_V, a.base_V, a.frequency_Hz, a.cycles, a.shape, t.bounds);
    (void)measure::plan_loops(t.bounds, r);  // refuses before anything runs
    StepLoopsProgress p("measure loops");
    const measure::LoopsRun run = t.board ? interruptible("measure loops", [&] {
        return hostlink::run_loops_device(*t.board, r, p.board_options(a.restart_stage, t.axis));
    })
                                          : measure::run_loops_sim(*t.scenario, t.case_spec, r, p.sim_progress());
    p.bar.done();
    std::ofstream csv(a.out);
    if (!csv) throw std::runtime_error("--out: cannot write " + a.out);
    measure::write_loops_csv(csv, run);
    if (!csv.flush()) throw std::runtime_error("--out: cannot write " + a.out);
    json out = measure::loops_report(r, run, t.source);
    out["out"] = a.out;
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
    add_source_options(cmd, a->scenario, a->sample, a->restart_stage, a->axis);
    cmd->add_option("--case", a->case_name, "case: its hysteresis override and sample type");
    add_number_list(cmd, "--amplitudes-v", a->amplitudes_V, "peak-to-peak command of each loop above the base, V (a,b,...)")
        ->required();
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

const bool registered_step_loops = register_command(46, add_step_loops);

}  // namespace
}  // namespace piezoloop::cli
