// Talking to a board over the link (docs/protocol.md): `piezoloop --device
// ADDR status | get | set | arm | disarm | clear-trip | save | load | forget
// | wave | stream | record`. JSON on stdout, errors on stderr with the exit codes of
// exit_codes.hpp (2: bad input, 3: link or device error, 4: a record or
// stream that lost data).
#include <algorithm>
#include <csignal>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <iostream>
#include <memory>
#include <optional>
#include <sstream>
#include <string>
#include <vector>

#include <nlohmann/json.hpp>

#include "commands.hpp"
#include "device_common.hpp"
#include "json/json_reader.hpp"
#include "link/csv_log.hpp"
#include "link/params_json.hpp"
#include "link/record_session.hpp"
#include "options/option_checks.hpp"
#include "piezoloop/trajectory.hpp"
#include "sim/plotting.hpp"
#include "status_text.hpp"

namespace piezoloop::cli {
namespace {

using nlohmann::json;
using hostlink::Client;

void print(const json& j) { std::cout << j.dump(1) << "\n"; }

// --json: inline JSON text (starting with '{') or a file.
json read_json_arg(const std::string& arg) {
    const auto first = arg.find_first_not_of(" \t\r\n");
    const bool text = first != std::string::npos && arg[first] == '{';
    if (!text && !std::ifstream(arg))
        throw std::invalid_argument("--json: '" + arg + "' is neither JSON text nor a readable file");
    try {
        return text ? hostjson::parse_text(arg, "text") : hostjson::read_file(arg);
    } catch (const hostjson::JsonError& e) {
        throw std::invalid_argument("--json: " + std::string(e.what()));
    }
}

json get_group(Client& c, link::ParamGroup g, uint8_t axis = 0) {
    json out;
    params::with_group(g, [&](auto tag) { out = hostlink::to_json(c.get<typename decltype(tag)::type>(axis)); });
    return out;
}

// A group of the --axis (kAllAxes: {"x": ..., "y": ...}); a board group
// (recorder, link, matrices) as it is.
json get_group_of(Client& c, link::ParamGroup g, int axis) {
    if (axis != kAllAxes || link::board_group(g)) return get_group(c, g, static_cast<uint8_t>(axis < 0 ? 0 : axis));
    json out;
    for (int a = 0; a < c.axis_count(); ++a) out[axis_name(a)] = get_group(c, g, static_cast<uint8_t>(a));
    return out;
}

// Merges j onto the board's group and sends it unless nothing changed (an
// unconfigured recorder read back by `get all` cannot be sent as it is).
template <class G>
void merge_and_set(Client& c, const json& j, uint8_t axis) {
    const G current = c.get<G>(axis);
    G g = current;
    hostlink::merge_json(j, g);
    if (!(g == current)) c.set(g, axis);
}

void set_group(Client& c, link::ParamGroup g, const json& j, uint8_t axis) {
    params::with_group(g, [&](auto tag) { merge_and_set<typename decltype(tag)::type>(c, j, axis); });
}

// The --axis option of the device commands.
void add_axis_option(CLI::App* cmd, std::string& axis, bool all) {
    cmd->add_option("--axis", axis,
                    all ? "x | y | z | all (default: the only axis; required on a multi-axis board)"
                        : "x | y | z (default: the only axis; required on a multi-axis board)");
}

// Groups in the order a session sends them: limits first (the limiter is
// "not configured" until then), rc after the feedback it needs.
const link::ParamGroup kGroupOrder[] = {link::ParamGroup::kLimits, link::ParamGroup::kFeedforward,
                                        link::ParamGroup::kFeedback, link::ParamGroup::kRepetitive,
                                        link::ParamGroup::kTrajectory, link::ParamGroup::kRecorder,
                                        link::ParamGroup::kLink, link::ParamGroup::kInputMatrix,
                                        link::ParamGroup::kOutputMatrix};

// ---- status / get / set -------------------------------------------------------

void add_status(CLI::App& app) {
    auto axis = std::make_shared<std::string>();
    CLI::App* cmd = app.add_subcommand("status", "Board identity, limits and live status as JSON (needs --device)");
    add_axis_option(cmd, *axis, true);
    cmd->callback([axis] {
        guarded([&] {
            Client c = open_device();
            const int a = resolve_axis(*axis, c.axis_count(), true);
            const link::StatusReply st = c.status();
            json out = {{"device", c.address()}, {"hello", hostlink::to_json(c.info())}, {"status", hostlink::to_json(st)}};
            if (a == kAllAxes) {
                out["axes"] = json::array();
                for (int i = 0; i < c.axis_count(); ++i) out["axes"].push_back(hostlink::axis_status_json(st, i));
            } else if (c.axis_count() > 1 || !axis->empty()) {
                out["axis"] = hostlink::axis_status_json(st, a);
            }
            print(out);
        });
    });
}

void add_get(CLI::App& app) {
    auto group = std::make_shared<std::string>();
    auto axis = std::make_shared<std::string>();
    CLI::App* cmd = app.add_subcommand("get", "Read a parameter group (or all) from the board as JSON (needs --device)");
    cmd->add_option("group", *group,
                    "feedforward | feedback | rc | limits | trajectory | recorder | link | input_matrix | "
                    "output_matrix | all")
        ->required();
    add_axis_option(cmd, *axis, true);
    cmd->callback([group, axis] {
        guarded([&] {
            const bool board_group = *group != "all" && link::board_group(hostlink::parse_group(*group));
            Client c = open_device();
            // A board group (recorder, link, the matrices) needs no axis.
            const int a = board_group && axis->empty() ? 0 : resolve_axis(*axis, c.axis_count(), true);
            if (*group == "all") {
                json out;
                for (const link::ParamGroup g : kGroupOrder) out[link::group_name(g)] = get_group_of(c, g, a);
                print(out);
            } else {
                print(get_group_of(c, hostlink::parse_group(*group), a));
            }
        });
    });
}

struct SetArgs {
    std::string group, json_arg, scenario, case_name, axis;
    double frequency_Hz = 0.0;
};

json set_scenario(Client& c, const SetArgs& a) {
    return send_scenario_case(c, a.scenario, a.case_name, a.frequency_Hz,
                              [](const std::string& line) { std::cerr << line << "\n"; });
}

void add_set(CLI::App& app) {
    auto a = std::make_shared<SetArgs>();
    CLI::App* cmd = app.add_subcommand(
        "set", "Write a parameter group (--json, merged onto the board's) or a scenario case's controller (needs --device)");
    cmd->add_option("group", a->group, "feedforward | feedback | rc | limits | trajectory | recorder | all");
    cmd->add_option("--json", a->json_arg, "the group's fields as JSON text or a file (all: {\"limits\": {...}, ...})");
    cmd->add_option("--scenario", a->scenario, "scenario file: send the case's limits, feedforward, feedback and rc")
        ->check(CLI::ExistingFile);
    cmd->add_option("--case", a->case_name, "case of the scenario");
    cmd->add_option("--frequency-hz", a->frequency_Hz, "reference frequency (RC period \"auto\")")
        ->check(CLI::Range(1e-6, 1e6));
    add_axis_option(cmd, a->axis, false);
    cmd->callback([a] {
        guarded([&] {
            if (!a->scenario.empty()) {
                if (!a->axis.empty()) throw std::invalid_argument("--axis: not with --scenario (it sets the case's axes)");
                if (a->case_name.empty()) throw std::invalid_argument("--scenario needs --case");
                if (!a->json_arg.empty() || !a->group.empty())
                    throw std::invalid_argument("give either GROUP --json or --scenario --case, not both");
                Client c = open_device();
                print(set_scenario(c, *a));
                return;
            }
            if (a->group.empty() || a->json_arg.empty())
                throw std::invalid_argument("usage: set GROUP --json FILE_OR_TEXT, or set --scenario S.json --case NAME");
            if (!a->case_name.empty()) throw std::invalid_argument("--case needs --scenario");
            const json j = read_json_arg(a->json_arg);
            std::vector<std::pair<link::ParamGroup, json>> todo;
            if (a->group == "all") {
                if (!j.is_object()) throw std::invalid_argument("--json: must be an object of groups");
                for (auto it = j.begin(); it != j.end(); ++it) (void)hostlink::parse_group(it.key());
                for (const link::ParamGroup g : kGroupOrder)
                    if (j.contains(link::group_name(g))) todo.emplace_back(g, j.at(link::group_name(g)));
            } else {
                todo.emplace_back(hostlink::parse_group(a->group), j);
            }
            Client c = open_device();
            // Board groups alone need no axis.
            bool board_only = true;
            for (const auto& [g, v] : todo) board_only = board_only && link::board_group(g);
            const auto axis = static_cast<uint8_t>(board_only && a->axis.empty() ? 0 : resolve_axis(a->axis, c.axis_count(), false));
            json out = {{"device", c.address()}, {"set", json::object()}};
            if (c.axis_count() > 1 && !board_only) out["axis"] = axis_name(axis);
            for (const auto& [g, v] : todo) {
                set_group(c, g, v, axis);
                out["set"][link::group_name(g)] = get_group(c, g, axis);
            }
            print(out);
        });
    });
}

void add_arm(CLI::App& app) {
    app.add_subcommand("arm", "Arm the loop (needs --device; limits must be set)")->callback([] {
        guarded([] {
            Client c = open_device();
            c.arm();
            print({{"device", c.address()}, {"armed", c.status().armed}});
        });
    });
    app.add_subcommand("disarm", "Disarm the loop: output to zero (needs --device)")->callback([] {
        guarded([] {
            Client c = open_device();
            c.disarm();
            print({{"device", c.address()}, {"armed", c.status().armed}});
        });
    });
    app.add_subcommand("clear-trip", "Clear a limiter trip while disarmed (needs --device)")->callback([] {
        guarded([] {
            Client c = open_device();
            c.clear_trip();
            const link::StatusReply st = c.status();
            print({{"device", c.address()}, {"tripped", st.tripped}, {"trip_reason", trip_reason_name(st.trip_reason)}});
        });
    });
    app.add_subcommand("stop", "Stop the running wave and setpoint stream, whoever started them; the setpoint holds "
                               "its last value and the loop stays armed (needs --device)")
        ->callback([] {
            guarded([] {
                Client c = open_device();
                c.stop_waves();
                c.stream_stop(false);
                const link::StatusReply st = c.status();
                print({{"device", c.address()}, {"wave_running", st.wave_running}, {"streaming", st.streaming},
                       {"armed", st.armed}});
            });
        });
}

// ---- storage --------------------------------------------------------------------

// The board's parameter storage (docs/storage.md). Each prints what the
// board then holds or runs: save and load the set (as `get all`), forget
// nothing but the fact.
void add_storage(CLI::App& app) {
    app.add_subcommand("save", "Store the board's current parameter set on the board; applied at its next boot "
                               "(needs --device; disarmed)")
        ->callback([] {
            guarded([] {
                Client c = open_device();
                c.save();
                json groups;
                for (const link::ParamGroup g : kGroupOrder) groups[link::group_name(g)] = get_group(c, g);
                print({{"device", c.address()}, {"saved", groups}});
            });
        });
    app.add_subcommand("load", "Validate the set stored on the board and apply it; a rejected or corrupt set "
                               "changes nothing (needs --device; disarmed)")
        ->callback([] {
            guarded([] {
                Client c = open_device();
                c.load();
                json groups;
                for (const link::ParamGroup g : kGroupOrder) groups[link::group_name(g)] = get_group(c, g);
                print({{"device", c.address()}, {"loaded", groups}});
            });
        });
    app.add_subcommand("forget", "Erase the set stored on the board: the next boot uses the safe default "
                                 "(needs --device; disarmed)")
        ->callback([] {
            guarded([] {
                Client c = open_device();
                c.forget();
                print({{"device", c.address()}, {"forgotten", true}});
            });
        });
}

// ---- wave -----------------------------------------------------------------------

void add_wave_options(CLI::App* cmd, WaveRequest& w, bool required) {
    // Checked by check_wave_request (device_common), as the Python module's.
    cmd->add_option("--trajectory", w.trajectory, "reference waveform: triangle | sine | square | raster");
    cmd->add_option("--frequency-hz", w.frequency_Hz, "reference frequency, 1e-4 to 5e5 Hz");
    auto* a = cmd->add_option("--amplitude-um", w.amplitude_um, "reference range, peak-to-peak, 1e-6 to 1e3 um");
    if (required) a->required();
    cmd->add_option("--offset", w.offset, "unipolar: from 0 up; bipolar: centred on 0 (default: the scenario's, else unipolar)");
    cmd->add_option("--scenario", w.scenario, "take the offset convention from this scenario (as `piezoloop sim`)")
        ->check(CLI::ExistingFile);
    cmd->add_option("--cycles", w.cycles, "periods to run, 0 = forever");
}

void add_wave(CLI::App& app) {
    struct Args {
        WaveRequest w;
        bool no_start = false, stop = false, arm = false;
        std::string axis;
    };
    auto a = std::make_shared<Args>();
    CLI::App* cmd = app.add_subcommand("wave", "Set the board's reference wave and start it (needs --device)");
    add_wave_options(cmd, a->w, false);
    add_axis_option(cmd, a->axis, false);
    cmd->add_flag("--no-start", a->no_start, "only set the trajectory group");
    cmd->add_flag("--arm", a->arm, "arm the loop at the wave's first tick (it must be disarmed)");
    cmd->add_flag("--stop", a->stop, "stop the running wave (the setpoint holds)");
    cmd->callback([a] {
        guarded([&] {
            if (!a->stop) check_wave_request(a->w);  // before the board is contacted
            Client c = open_device();
            const auto axis = static_cast<uint8_t>(resolve_axis(a->axis, c.axis_count(), false));
            if (a->stop) {
                c.stop_wave(axis);
                print({{"device", c.address()}, {"wave_running", c.status().axis_wave_running[axis]}});
                return;
            }
            const link::TrajectoryParams p = wave_params(a->w, c.info().loop_rate_Hz);
            c.set(p, axis);
            if (!a->no_start) {
                if (c.status().axis_wave_running[axis]) c.stop_wave(axis);
                // A wave started from the command line runs on after it exits.
                c.start_wave(hostlink::wave_flag::kDetached | (a->arm ? hostlink::wave_flag::kArm : 0), axis);
            }
            const link::StatusReply st = c.status();
            json out = {{"device", c.address()}, {"trajectory", hostlink::to_json(c.get<link::TrajectoryParams>(axis))},
                        {"wave_running", st.axis_wave_running[axis]}, {"armed", st.axis_armed[axis]}};
            if (c.axis_count() > 1) out["axis"] = axis_name(axis);
            print(out);
        });
    });
}

// ---- stream -----------------------------------------------------------------------

// The reference the board's own wave generator would make, tick by tick.
std::vector<float> generate_setpoints(const link::TrajectoryParams& p, double rate_Hz, double duration_s) {
    TrajectoryConfig cfg;
    cfg.waveform = p.waveform;
    cfg.amplitude_um = p.amplitude_um;
    cfg.offset_um = p.offset_um;
    cfg.frequency_Hz = p.frequency_Hz;
    cfg.sample_rate_Hz = static_cast<float>(rate_Hz);
    cfg.cycles = p.cycles;
    cfg.start_phase_cycles = p.start_phase_cycles;
    cfg.return_fraction = p.return_fraction;
    cfg.duty = p.duty;
    TrajectoryGenerator<float> g;
    if (const Status s = g.configure(cfg); !s.ok()) throw std::invalid_argument("trajectory: " + piezoloop::describe(s));
    const auto n = static_cast<std::size_t>(std::llround(duration_s * rate_Hz));
    std::vector<float> out(n);
    for (float& x : out) x = g.step();
    return out;
}

void add_stream(CLI::App& app) {
    struct Args {
        std::string file, column, axis;
        WaveRequest w;
        double duration_s = 0.0;
        std::optional<double> prefill;
    };
    auto a = std::make_shared<Args>();
    CLI::App* cmd = app.add_subcommand(
        "stream", "Stream setpoints (a CSV column, or a generated wave) to the board's FIFO (needs --device)");
    cmd->add_option("--file", a->file, "CSV of setpoints (um): column setpoint_um or r_um, else the first")
        ->check(CLI::ExistingFile);
    cmd->add_option("--column", a->column, "CSV column to stream");
    add_wave_options(cmd, a->w, false);
    cmd->add_option("--duration-s", a->duration_s, "length of a generated stream")->check(CLI::Range(1e-6, 1e5));
    cmd->add_option("--prefill", a->prefill,
                    "setpoints buffered before the tick consumes, 0 to 32768 (default: the FIFO, or all)");
    add_axis_option(cmd, a->axis, false);
    cmd->callback([a] {
        guarded([&] {
            if (a->file.empty() == !(a->w.amplitude_um > 0.0))
                throw std::invalid_argument("give either --file or a generated wave (--trajectory ... --amplitude-um A --duration-s D)");
            if (a->file.empty() && !(a->duration_s > 0.0)) throw std::invalid_argument("--duration-s: required with a generated wave");
            (void)options::stream_prefill(a->prefill, 0, 0);  // refused before the board is contacted
            if (a->file.empty()) check_wave_request(a->w);
            std::vector<float> sp;
            if (!a->file.empty()) sp = hostlink::read_setpoints_csv(a->file, a->column);
            Client c = open_device(5000);
            const auto axis = static_cast<uint8_t>(resolve_axis(a->axis, c.axis_count(), false));
            const double rate = c.info().loop_rate_Hz;
            if (sp.empty()) sp = generate_setpoints(wave_params(a->w, rate), rate, a->duration_s);
            const uint16_t prefill = options::stream_prefill(a->prefill, c.info().setpoint_capacity, sp.size());
            ProgressBar bar("stream");
            const hostlink::StreamResult r = c.stream(sp, prefill, [&](double f) { bar.update(f); }, axis);
            bar.done();
            print({{"device", c.address()},
                   {"setpoints", sp.size()},
                   {"sent", r.sent},
                   {"consumed", r.consumed},
                   {"underruns", r.underruns},
                   {"blocks", r.blocks},
                   {"prefill", prefill},
                   {"capacity", r.capacity},
                   {"drained", r.drained},
                   {"loop_rate_Hz", rate},
                   {"wall_s", r.wall_s}});
            if (!r.drained) throw hostlink::LinkError("the stream did not drain (device still streaming)");
        });
    });
}

// ---- record -------------------------------------------------------------------------

struct RecordArgs {
    std::string signals = "r,y,e,u";
    double duration_s = 0.0;
    uint32_t decimation = 1;
    bool start_wave = false, restart_stage = false, every_axis = false;
    std::string out, plot, axis;
    WaveRequest w;
    bool wave_given = false;
    double stall_s = 5.0;
};

int run_record(const RecordArgs& a) {
    hostlink::RecordOptions o;
    o.signals = hostlink::parse_signal_list(a.signals);
    auto has = [&](uint8_t id) { return std::find(o.signals.begin(), o.signals.end(), id) != o.signals.end(); };
    if (!a.plot.empty() && !(has(0) && has(1) && has(3))) throw std::invalid_argument("--plot: needs the signals r, y and u");
    if (a.restart_stage && !a.start_wave) throw std::invalid_argument("--restart-stage: only with --start-wave");
    if (a.every_axis && !a.start_wave) throw std::invalid_argument("--every-axis: only with --start-wave");
    options::check_record_options(a.duration_s, a.decimation, a.stall_s);
    o.duration_s = a.duration_s;
    o.decimation = a.decimation;
    o.start_wave = a.start_wave;
    o.restart_stage = a.restart_stage;
    o.every_axis = a.every_axis;
    o.stall_s = a.stall_s;
    o.out_csv = a.out;

    Client c = open_device(5000);
    const int axis = resolve_axis(a.axis, c.axis_count(), true);
    if (axis == kAllAxes) {
        // Every axis's signals, axis by axis (columns r_x_um, y_x_um, r_y_um, ...).
        const std::vector<uint8_t> ids = o.signals;
        o.signals.clear();
        for (uint8_t i = 0; i < c.axis_count(); ++i)
            for (const uint8_t id : ids) {
                o.signals.push_back(id);
                o.signal_axes.push_back(i);
            }
        if (!a.plot.empty()) throw std::invalid_argument("--plot: one axis (not with --axis all)");
        if (a.wave_given) throw std::invalid_argument("--trajectory: one axis's wave (set each with `wave --no-start --axis A`)");
    }
    o.axis = static_cast<uint8_t>(axis == kAllAxes ? 0 : axis);
    if (a.wave_given) o.wave = wave_params(a.w, c.info().loop_rate_Hz);
    ProgressBar bar("record");
    o.progress = [&](double f) { bar.update(f); };
    // Ctrl-C or SIGTERM: the session stops collecting, stops the recorder
    // on the board and writes what arrived, marked incomplete.
    const StopSignals stop_signals;
    o.stop_requested = [] { return StopSignals::requested(); };
    const hostlink::RecordResult r = hostlink::record(c, o);
    bar.done();
    print(hostlink::summary_json(r));
    if (!a.plot.empty() && r.frames > 0) sim::plot_spec("plot_sim.py", hostlink::plot_spec(r, std::filesystem::absolute(a.plot).string()));
    if (!r.complete()) {
        std::cerr << "error: record incomplete:" << r.problems()
                  << (a.out.empty() ? "" : " what arrived is in " + a.out + " (marked incomplete);") << " see the summary\n";
        return kExitLostData;
    }
    return kExitOk;
}

void add_record(CLI::App& app) {
    auto a = std::make_shared<RecordArgs>();
    CLI::App* cmd = app.add_subcommand(
        "record", "Record signals from the board to CSV; summary JSON with loss counts, metrics, log hash "
                  "(needs --device)");
    cmd->add_option("--signals", a->signals, "comma-separated: r, y, e, u, u_ff, u_fb, u_rc (default r,y,e,u)");
    cmd->add_option("--duration-s", a->duration_s,
                    "device time to record, 1e-6 to 1e5 s (with --start-wave: after the wave's approach to its "
                    "first point)")
        ->required();
    cmd->add_option("--decimation", a->decimation, "keep every N-th tick, 1 to 2^24");
    cmd->add_flag("--start-wave", a->start_wave,
                  "start the trajectory with the recorder (and the loop, if disarmed) at the same tick");
    cmd->add_flag("--every-axis", a->every_axis,
                  "with --start-wave on a board of axes: start every axis's wave (as set with `wave --no-start "
                  "--axis A`) at the same tick");
    cmd->add_flag("--restart-stage", a->restart_stage,
                  "with --start-wave: emulated stage and loop from rest (a record equal to `piezoloop sim`)");
    cmd->add_option("--out", a->out, "CSV file: t_s and one column per signal with its unit");
    cmd->add_option("--plot", a->plot, "draw r, y, e and u to a PNG (tools/plot_sim.py)");
    cmd->add_option("--stall-s", a->stall_s, "give up when no frames arrive for this long, 0.1 to 3600 s");
    add_axis_option(cmd, a->axis, true);
    WaveRequest& w = a->w;
    // Checked by check_wave_request (device_common), as the Python module's.
    auto* t = cmd->add_option("--trajectory", w.trajectory,
                              "set this reference wave first (as `wave --no-start`): triangle | sine | square | raster");
    cmd->add_option("--frequency-hz", w.frequency_Hz, "reference frequency, 1e-4 to 5e5 Hz");
    auto* amp = cmd->add_option("--amplitude-um", w.amplitude_um, "reference range, peak-to-peak, 1e-6 to 1e3 um");
    cmd->add_option("--offset", w.offset, "unipolar | bipolar (default: the scenario's, else unipolar)");
    cmd->add_option("--scenario", w.scenario, "take the offset convention from this scenario")->check(CLI::ExistingFile);
    cmd->add_option("--cycles", w.cycles, "periods the wave runs, 0 = forever");
    cmd->callback([a, t, amp] {
        guarded([&] {
            a->wave_given = t->count() > 0 || amp->count() > 0;
            if (a->wave_given) check_wave_request(a->w);  // before the board is contacted
            return run_record(*a);
        });
    });
}

void add_device_commands(CLI::App& app) {
    add_status(app);
    add_get(app);
    add_set(app);
    add_arm(app);
    add_storage(app);
    add_wave(app);
    add_stream(app);
    add_record(app);
}

const bool registered_device_commands = register_command(60, add_device_commands);

}  // namespace
}  // namespace piezoloop::cli
