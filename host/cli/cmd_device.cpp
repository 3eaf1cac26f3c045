// Talking to a board over the link (docs/protocol.md): `piezoloop --device
// ADDR status | get | set | arm | disarm | clear-trip | wave | stream |
// record`. JSON on stdout, errors on stderr with a non-zero exit (2: bad
// input, 3: link or device error, 4: a record or stream that lost data).
#include <algorithm>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <iostream>
#include <memory>
#include <sstream>
#include <string>
#include <vector>

#include <nlohmann/json.hpp>

#include "commands.hpp"
#include "device_common.hpp"
#include "link/params_json.hpp"
#include "piezoloop/reference_run.hpp"
#include "piezoloop/trajectory.hpp"
#include "sim/plotting.hpp"
#include "sim/window_metrics.hpp"
#include "status_text.hpp"

namespace piezoloop::cli {
namespace {

using nlohmann::json;
using hostlink::Client;

void print(const json& j) { std::cout << j.dump(1) << "\n"; }

// --json: inline JSON text (starting with '{') or a file.
json read_json_arg(const std::string& arg) {
    std::string text = arg;
    const auto first = arg.find_first_not_of(" \t\r\n");
    if (first == std::string::npos || arg[first] != '{') {
        std::ifstream f(arg);
        if (!f) throw std::invalid_argument("--json: '" + arg + "' is neither JSON text nor a readable file");
        std::stringstream ss;
        ss << f.rdbuf();
        text = ss.str();
    }
    try {
        return json::parse(text);
    } catch (const json::parse_error& e) {
        throw std::invalid_argument("--json: " + std::string(e.what()));
    }
}

json get_group(Client& c, link::ParamGroup g) {
    switch (g) {
        case link::ParamGroup::kFeedforward: return hostlink::to_json(c.get<link::FeedforwardParams>());
        case link::ParamGroup::kFeedback: return hostlink::to_json(c.get<link::FeedbackParams>());
        case link::ParamGroup::kRepetitive: return hostlink::to_json(c.get<link::RepetitiveParams>());
        case link::ParamGroup::kLimits: return hostlink::to_json(c.get<link::LimitsParams>());
        case link::ParamGroup::kTrajectory: return hostlink::to_json(c.get<link::TrajectoryParams>());
        case link::ParamGroup::kRecorder: return hostlink::to_json(c.get<link::RecorderParams>());
    }
    return {};
}

// Merges j onto the board's group and sends it unless nothing changed (an
// unconfigured recorder read back by `get all` cannot be sent as it is).
template <class G>
void merge_and_set(Client& c, const json& j) {
    const G current = c.get<G>();
    G g = current;
    hostlink::merge_json(j, g);
    if (!(g == current)) c.set(g);
}

void set_group(Client& c, link::ParamGroup g, const json& j) {
    switch (g) {
        case link::ParamGroup::kFeedforward: return merge_and_set<link::FeedforwardParams>(c, j);
        case link::ParamGroup::kFeedback: return merge_and_set<link::FeedbackParams>(c, j);
        case link::ParamGroup::kRepetitive: return merge_and_set<link::RepetitiveParams>(c, j);
        case link::ParamGroup::kLimits: return merge_and_set<link::LimitsParams>(c, j);
        case link::ParamGroup::kTrajectory: return merge_and_set<link::TrajectoryParams>(c, j);
        case link::ParamGroup::kRecorder: return merge_and_set<link::RecorderParams>(c, j);
    }
}

// Groups in the order a session sends them: limits first (the limiter is
// "not configured" until then), rc after the feedback it needs.
const link::ParamGroup kGroupOrder[] = {link::ParamGroup::kLimits, link::ParamGroup::kFeedforward,
                                        link::ParamGroup::kFeedback, link::ParamGroup::kRepetitive,
                                        link::ParamGroup::kTrajectory, link::ParamGroup::kRecorder};

// ---- status / get / set -------------------------------------------------------

void add_status(CLI::App& app) {
    CLI::App* cmd = app.add_subcommand("status", "Board identity, limits and live status as JSON (needs --device)");
    cmd->callback([] {
        guarded([] {
            Client c = open_device();
            print({{"device", c.address()}, {"hello", hostlink::to_json(c.info())}, {"status", hostlink::to_json(c.status())}});
        });
    });
}

void add_get(CLI::App& app) {
    auto group = std::make_shared<std::string>();
    CLI::App* cmd = app.add_subcommand("get", "Read a parameter group (or all) from the board as JSON (needs --device)");
    cmd->add_option("group", *group, "feedforward | feedback | rc | limits | trajectory | recorder | all")->required();
    cmd->callback([group] {
        guarded([&] {
            if (*group != "all") (void)hostlink::parse_group(*group);
            Client c = open_device();
            if (*group == "all") {
                json out;
                for (const link::ParamGroup g : kGroupOrder) out[link::group_name(g)] = get_group(c, g);
                print(out);
            } else {
                print(get_group(c, hostlink::parse_group(*group)));
            }
        });
    });
}

struct SetArgs {
    std::string group, json_arg, scenario, case_name;
    double frequency_Hz = 0.0;
};

json set_scenario(Client& c, const SetArgs& a) {
    const sim::Scenario s = sim::load_scenario(a.scenario);
    const sim::CaseSpec& cs = s.find_case(a.case_name);
    const link::HelloReply& h = c.info();
    if (cs.feedforward.kind == "dahl" && !(h.capabilities & link::cap::kDahl))
        throw std::invalid_argument("case " + cs.name + ": Dahl feedforward, which this board (" +
                                    std::string(h.board.data()) + ", Q31 pipeline) does not run");
    if (std::fabs(h.loop_rate_Hz - s.rate_Hz) > 1e-6 * s.rate_Hz)
        throw std::invalid_argument("scenario " + s.name + " is discretised at " + std::to_string(s.rate_Hz) +
                                    " Hz, the board runs at " + std::to_string(h.loop_rate_Hz) +
                                    " Hz (`piezoloop emulate --scenario` starts a board at the scenario's rate)");
    // Built for the board's sample type, as `piezoloop sim --sample` does:
    // a Q31 board gets the fixed-point scaling of the feedback sections.
    sim::CaseSpec cb = cs;
    const bool board_q31 = h.sample_format == link::SampleFormat::kQ31;
    if ((cb.sample == sim::SampleType::kQ31) != board_q31)
        std::cerr << "note: case " << cs.name << " is simulated with " << sim::to_string(cb.sample)
                  << " samples; built for this board's " << (board_q31 ? "q31" : "float")
                  << " (compare with `piezoloop sim --sample " << (board_q31 ? "q31" : "float") << "`)\n";
    cb.sample = board_q31 ? sim::SampleType::kQ31 : sim::SampleType::kFloat;
    sim::BuildOptions bo;
    bo.reference_frequency_Hz = a.frequency_Hz;
    bo.check_realisation = false;
    sim::BuiltCase b;
    try {
        b = sim::build_case(s, cb, bo);
    } catch (const std::exception& e) {
        std::string m = e.what();
        if (m.find("periodic reference") != std::string::npos) m += " (give --frequency-hz)";
        throw std::invalid_argument(m);
    }
    if (c.status().armed)
        throw std::invalid_argument("the loop is armed: limits and block kinds change only while disarmed "
                                    "(`piezoloop --device " + c.address() + " disarm` first)");
    CaseGroups g = case_groups(b.model.params);
    std::vector<std::string> clipped;
    g.limits = clip_to_hard_limits(g.limits, h, clipped);
    for (const std::string& m : clipped) std::cerr << "clipped: " << m << "\n";
    json sent = json::array();
    c.set(g.limits);
    sent.push_back("limits");
    // RC needs feedback: switch it off before the feedback changes, on after.
    if (!g.rc.enabled) {
        c.set(g.rc);
        sent.push_back("rc");
    }
    // pi_series needs a feedback (its output feeds the inverse): set the
    // feedback first when going to it, the feedforward first otherwise (so
    // leaving pi_series never sees it without a feedback).
    const bool series = g.feedforward.kind == FeedforwardKind::kPiSeries;
    if (!series) {
        c.set(g.feedforward);
        sent.push_back("feedforward");
    }
    c.set(g.feedback);
    sent.push_back("feedback");
    if (series) {
        c.set(g.feedforward);
        sent.push_back("feedforward");
    }
    if (g.rc.enabled) {
        c.set(g.rc);
        sent.push_back("rc");
    }
    json out = {{"device", c.address()}, {"scenario", s.name}, {"case", cs.name}, {"label", cs.label},
                {"sent", sent},          {"clipped", clipped}};
    for (const std::string& n : b.notes) out["notes"].push_back(n);
    return out;
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
    cmd->callback([a] {
        guarded([&] {
            if (!a->scenario.empty()) {
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
            json out = {{"device", c.address()}, {"set", json::object()}};
            for (const auto& [g, v] : todo) {
                set_group(c, g, v);
                out["set"][link::group_name(g)] = get_group(c, g);
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
}

// ---- wave -----------------------------------------------------------------------

void add_wave_options(CLI::App* cmd, WaveRequest& w, bool required) {
    auto* t = cmd->add_option("--trajectory", w.trajectory, "reference waveform")
                  ->check(CLI::IsMember({"triangle", "sine", "square", "raster"}));
    auto* f = cmd->add_option("--frequency-hz", w.frequency_Hz, "reference frequency")->check(CLI::Range(1e-4, 5e5));
    auto* a = cmd->add_option("--amplitude-um", w.amplitude_um, "reference range, peak-to-peak (um)")
                  ->check(CLI::Range(1e-6, 1e3));
    if (required) a->required();
    (void)t;
    (void)f;
    cmd->add_option("--offset", w.offset, "unipolar: from 0 up; bipolar: centred on 0 (default: the scenario's, else unipolar)")
        ->check(CLI::IsMember({"unipolar", "bipolar"}));
    cmd->add_option("--scenario", w.scenario, "take the offset convention from this scenario (as `piezoloop sim`)")
        ->check(CLI::ExistingFile);
    cmd->add_option("--cycles", w.cycles, "periods to run, 0 = forever");
}

void add_wave(CLI::App& app) {
    struct Args {
        WaveRequest w;
        bool no_start = false, stop = false, arm = false;
    };
    auto a = std::make_shared<Args>();
    CLI::App* cmd = app.add_subcommand("wave", "Set the board's reference wave and start it (needs --device)");
    add_wave_options(cmd, a->w, false);
    cmd->add_flag("--no-start", a->no_start, "only set the trajectory group");
    cmd->add_flag("--arm", a->arm, "arm the loop at the wave's first tick (it must be disarmed)");
    cmd->add_flag("--stop", a->stop, "stop the running wave (the setpoint holds)");
    cmd->callback([a] {
        guarded([&] {
            Client c = open_device();
            if (a->stop) {
                c.stop_wave();
                print({{"device", c.address()}, {"wave_running", c.status().wave_running}});
                return;
            }
            const link::TrajectoryParams p = wave_params(a->w, c.info().loop_rate_Hz);
            c.set(p);
            if (!a->no_start) {
                if (c.status().wave_running) c.stop_wave();
                c.start_wave(a->arm ? hostlink::wave_flag::kArm : 0);
            }
            const link::StatusReply st = c.status();
            print({{"device", c.address()}, {"trajectory", hostlink::to_json(c.get<link::TrajectoryParams>())},
                   {"wave_running", st.wave_running}, {"armed", st.armed}});
        });
    });
}

// ---- stream -----------------------------------------------------------------------

std::vector<float> read_setpoints(const std::string& path, const std::string& column) {
    std::ifstream f(path);
    if (!f) throw std::invalid_argument("--file: cannot read " + path);
    std::vector<float> out;
    std::string line;
    int col = -1;
    std::size_t line_no = 0;
    auto split = [](const std::string& l) {
        std::vector<std::string> cells;
        std::string cell;
        std::stringstream ss(l);
        while (std::getline(ss, cell, ',')) cells.push_back(cell);
        return cells;
    };
    while (std::getline(f, line)) {
        ++line_no;
        if (!line.empty() && line.back() == '\r') line.pop_back();
        if (line.empty() || line[0] == '#') continue;
        const std::vector<std::string> cells = split(line);
        if (col < 0) {
            char* end = nullptr;
            std::strtod(cells[0].c_str(), &end);
            const bool header = end == cells[0].c_str();
            if (header) {
                const std::vector<std::string> wanted =
                    column.empty() ? std::vector<std::string>{"setpoint_um", "r_um"} : std::vector<std::string>{column};
                for (const std::string& w : wanted)
                    for (std::size_t i = 0; i < cells.size() && col < 0; ++i)
                        if (cells[i] == w) col = static_cast<int>(i);
                if (col < 0 && !column.empty()) throw std::invalid_argument("--column: no column '" + column + "' in " + path);
                if (col < 0) col = 0;
                continue;
            }
            if (!column.empty()) throw std::invalid_argument("--column: " + path + " has no header line");
            col = 0;
        }
        if (static_cast<std::size_t>(col) >= cells.size())
            throw std::invalid_argument(path + ":" + std::to_string(line_no) + ": missing column " + std::to_string(col + 1));
        char* end = nullptr;
        const double v = std::strtod(cells[static_cast<std::size_t>(col)].c_str(), &end);
        if (end == cells[static_cast<std::size_t>(col)].c_str() || !std::isfinite(v))
            throw std::invalid_argument(path + ":" + std::to_string(line_no) + ": not a number");
        out.push_back(static_cast<float>(v));
    }
    if (out.empty()) throw std::invalid_argument("--file: no setpoints in " + path);
    return out;
}

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
        std::string file, column;
        WaveRequest w;
        double duration_s = 0.0;
        int prefill = -1;
    };
    auto a = std::make_shared<Args>();
    CLI::App* cmd = app.add_subcommand(
        "stream", "Stream setpoints (a CSV column, or a generated wave) to the board's FIFO (needs --device)");
    cmd->add_option("--file", a->file, "CSV of setpoints (um): column setpoint_um or r_um, else the first")
        ->check(CLI::ExistingFile);
    cmd->add_option("--column", a->column, "CSV column to stream");
    add_wave_options(cmd, a->w, false);
    cmd->add_option("--duration-s", a->duration_s, "length of a generated stream")->check(CLI::Range(1e-6, 1e5));
    cmd->add_option("--prefill", a->prefill, "setpoints buffered before the tick consumes (default: the FIFO, or all)")
        ->check(CLI::Range(0, 32768));
    cmd->callback([a] {
        guarded([&] {
            if (a->file.empty() == !(a->w.amplitude_um > 0.0))
                throw std::invalid_argument("give either --file or a generated wave (--trajectory ... --amplitude-um A --duration-s D)");
            if (a->file.empty() && !(a->duration_s > 0.0)) throw std::invalid_argument("--duration-s: required with a generated wave");
            std::vector<float> sp;
            if (!a->file.empty()) sp = read_setpoints(a->file, a->column);
            Client c = open_device(5000);
            const double rate = c.info().loop_rate_Hz;
            if (sp.empty()) sp = generate_setpoints(wave_params(a->w, rate), rate, a->duration_s);
            const std::size_t cap = c.info().setpoint_capacity;
            const uint16_t prefill = static_cast<uint16_t>(
                a->prefill >= 0 ? std::min<std::size_t>(static_cast<std::size_t>(a->prefill), cap) : std::min(cap, sp.size()));
            ProgressBar bar("stream");
            const hostlink::StreamResult r = c.stream(sp, prefill, [&](double f) { bar.update(f); });
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
            if (!r.drained) throw std::runtime_error("the stream did not drain (device still streaming)");
        });
    });
}

// ---- record -------------------------------------------------------------------------

struct RecordArgs {
    std::string signals = "r,y,e,u";
    double duration_s = 0.0;
    uint32_t decimation = 1;
    bool start_wave = false, restart_stage = false;
    std::string out, plot;
    WaveRequest w;
    bool wave_given = false;
    double stall_s = 5.0;
};

std::vector<std::string> split_list(const std::string& s) {
    std::vector<std::string> out;
    std::string cell;
    std::stringstream ss(s);
    while (std::getline(ss, cell, ',')) {
        cell.erase(0, cell.find_first_not_of(' '));
        cell.erase(cell.find_last_not_of(' ') + 1);
        if (!cell.empty()) out.push_back(cell);
    }
    return out;
}

int run_record(const RecordArgs& a) {
    const std::vector<std::string> names = split_list(a.signals);
    if (names.empty()) throw std::invalid_argument("--signals: at least one of r, y, e, u, u_ff, u_fb, u_rc");
    std::vector<uint8_t> ids;
    for (const std::string& n : names) {
        const uint8_t id = hostlink::parse_signal(n);
        if (std::find(ids.begin(), ids.end(), id) != ids.end()) throw std::invalid_argument("--signals: " + n + " twice");
        ids.push_back(id);
    }
    auto has = [&](uint8_t id) { return std::find(ids.begin(), ids.end(), id) != ids.end(); };
    if (!a.plot.empty() && !(has(0) && has(1) && has(3))) throw std::invalid_argument("--plot: needs the signals r, y and u");
    if (a.restart_stage && !a.start_wave) throw std::invalid_argument("--restart-stage: only with --start-wave");

    Client c = open_device(5000);
    const link::HelloReply h = c.info();
    const double rate = h.loop_rate_Hz;
    if (ids.size() > h.recorder_channels)
        throw std::invalid_argument("--signals: this board records " + std::to_string(h.recorder_channels) + " channels");
    // The device records exactly recorder_channels channels: the requested
    // ones first, then others to fill (not written out).
    link::RecorderParams rec;
    rec.channel_count = h.recorder_channels;
    {
        std::vector<uint8_t> ch = ids;
        for (uint8_t s = 0; s < 7 && ch.size() < h.recorder_channels; ++s)
            if (std::find(ch.begin(), ch.end(), s) == ch.end()) ch.push_back(s);
        for (std::size_t i = 0; i < ch.size(); ++i) rec.channels[i] = ch[i];
    }
    rec.decimation = a.decimation;
    rec.mode = RecordMode::kContinuous;
    rec.trigger = TriggerMode::kImmediate;

    if (a.wave_given) c.set(wave_params(a.w, rate));
    c.set(rec);
    const link::TrajectoryParams wave = c.get<link::TrajectoryParams>();
    link::StatusReply st = c.status();
    std::vector<std::string> notes;
    if (a.start_wave) {
        if (st.wave_running) c.stop_wave();
        if (a.restart_stage && st.armed) {
            c.disarm();
            notes.push_back("disarmed to restart the loop from rest with the wave");
            st.armed = false;
        }
        uint8_t flags = hostlink::wave_flag::kArmRecorder;
        if (!st.armed) flags |= hostlink::wave_flag::kArm;
        if (a.restart_stage) flags |= hostlink::wave_flag::kRestartStage;
        c.start_wave(flags);
    } else {
        c.recorder_arm();
    }
    const bool wave_running = a.start_wave || st.wave_running;

    const uint64_t want = static_cast<uint64_t>(std::llround(a.duration_s * rate / a.decimation));
    if (want == 0) throw std::invalid_argument("--duration-s: shorter than one recorded frame");
    const uint64_t last_tick = (want - 1) * a.decimation;
    ProgressBar bar("record");
    auto last_progress = std::chrono::steady_clock::now();
    std::size_t last_size = 0;
    bool stalled = false;
    for (;;) {
        c.pump(std::chrono::milliseconds(20));
        const std::size_t n = c.log().size();
        if (n > 0 && c.log().tick(n - 1) >= last_tick) break;
        if (n != last_size) {
            last_size = n;
            last_progress = std::chrono::steady_clock::now();
        } else if (std::chrono::duration<double>(std::chrono::steady_clock::now() - last_progress).count() > a.stall_s) {
            stalled = true;
            break;
        }
        bar.update(n > 0 ? static_cast<double>(c.log().tick(n - 1)) / static_cast<double>(last_tick + 1) : 0.0);
    }
    bar.update(1.0);
    bar.done();
    c.recorder_stop();
    c.pump(std::chrono::milliseconds(50));
    c.log().finish();
    const hostlink::LogCollector& log = c.log();
    const hostlink::LogStats& ls = log.stats();
    st = c.status();

    // Frames within the requested duration.
    std::size_t frames = 0;
    while (frames < log.size() && log.tick(frames) <= last_tick) ++frames;
    auto column = [&](uint8_t id) -> int {
        for (std::size_t i = 0; i < log.channel_count(); ++i)
            if (log.channels()[i] == id) return static_cast<int>(i);
        return -1;
    };
    std::vector<int> cols;
    for (const uint8_t id : ids) {
        cols.push_back(column(id));
        if (frames > 0 && cols.back() < 0) throw std::runtime_error("the log blocks do not carry signal " + std::string(hostlink::signal_name(id)));
    }
    auto value = [&](std::size_t i, uint8_t id) {
        const int k = column(id);
        return hostlink::log_sample_physical(log.raw(i)[k], id, log.format(), h);
    };

    if (!a.out.empty()) {
        std::ofstream f(a.out);
        if (!f) throw std::runtime_error("--out: cannot write " + a.out);
        f << "t_s";
        for (const uint8_t id : ids) f << "," << hostlink::signal_name(id) << "_" << hostlink::signal_unit(id);
        f << "\n";
        char cell[64];
        for (std::size_t i = 0; i < frames; ++i) {
            std::snprintf(cell, sizeof cell, "%.9g", static_cast<double>(log.tick(i)) / rate);
            f << cell;
            for (std::size_t k = 0; k < ids.size(); ++k) {
                std::snprintf(cell, sizeof cell, ",%.9g",
                              hostlink::log_sample_physical(log.raw(i)[cols[k]], ids[k], log.format(), h));
                f << cell;
            }
            f << "\n";
        }
    }

    json out = {{"device", c.address()},
                {"board", h.board.data()},
                {"loop_rate_Hz", rate},
                {"signals", names},
                {"decimation", a.decimation},
                {"frames", frames},
                {"expected_frames", want},
                {"blocks", ls.blocks},
                {"lost_blocks", ls.lost_blocks},
                {"out_of_order", ls.out_of_order},
                {"duplicates", ls.duplicates},
                {"tick_gaps", ls.tick_gaps},
                {"missing_frames", ls.missing_frames},
                {"recorder_overruns", ls.recorder_overruns},
                {"inconsistent_blocks", ls.inconsistent},
                {"stale_replies", c.counters().stale_replies},
                {"bad_frames", c.counters().bad_replies},
                {"host_link_dropped", c.link_counters().dropped()},
                {"tick_overruns", st.tick.overruns},
                {"stalled", stalled}};
    if (!notes.empty()) out["notes"] = notes;

    // log_hash: the fold of `piezoloop sim --hash` (r, y, u bit patterns of
    // each frame, in the board's sample type) over the recorded frames.
    if (has(0) && has(1) && has(3) && frames > 0) {
        reference::LogHash hash;
        const int kr = column(0), ky = column(1), ku = column(3);
        for (std::size_t i = 0; i < frames; ++i) {
            hash.add(log.raw(i)[kr]);
            hash.add(log.raw(i)[ky]);
            hash.add(log.raw(i)[ku]);
        }
        out["log_hash"] = sim::hex64(hash.value());
    }
    // Metrics (docs/models.md) over the last reference period in the record (the
    // steady-state window `piezoloop sim` uses), else over the whole record.
    std::size_t window_start = 0;
    if (has(0) && has(1) && frames > 1) {
        std::string window = "whole record";
        if (wave_running && wave.frequency_Hz > 0.0f) {
            const double period_frames = rate / wave.frequency_Hz / a.decimation;
            const auto p = static_cast<std::size_t>(std::llround(period_frames));
            if (p >= 2 && p <= frames) {
                window_start = frames - p;
                window = "last reference period";
            }
        }
        sim::WindowMetrics m(wave_running ? wave.offset_um : 0.0);
        for (std::size_t i = window_start; i < frames; ++i) m.add(value(i, 0), value(i, 1));
        const sim::TrackingMetrics t = m.tracking();
        const double hyst = m.hysteresis_pct();
        out["window"] = window;
        out["window_frames"] = frames - window_start;
        out["hysteresis_pct"] = hyst >= 0.0 ? json(hyst) : json();
        out["e_max_pct"] = t.e_max_pct;
        out["e_rms_pct"] = t.e_rms_pct;
        out["e_max_um"] = t.e_max_um;
        out["e_rms_um"] = t.e_rms_um;
        out["e_pp_um"] = t.e_pp_um;
        out["range_um"] = t.range_um;
    }
    print(out);

    if (!a.plot.empty() && frames > 0) {
        json spec;
        spec["kind"] = "sim";
        spec["output"] = std::filesystem::absolute(a.plot).string();
        char title[256];
        if (wave_running)
            std::snprintf(title, sizeof title, "%s (%s): record, %s %g Hz, %g um p-p", h.board.data(), c.address().c_str(),
                          hostlink::waveform_name(wave.waveform), static_cast<double>(wave.frequency_Hz),
                          2.0 * static_cast<double>(wave.amplitude_um));
        else
            std::snprintf(title, sizeof title, "%s (%s): record", h.board.data(), c.address().c_str());
        spec["title"] = title;
        json t_s = json::array(), r = json::array(), y = json::array(), u = json::array();
        for (std::size_t i = 0; i < frames; ++i) {
            t_s.push_back(static_cast<double>(log.tick(i)) / rate);
            r.push_back(value(i, 0));
            y.push_back(value(i, 1));
            u.push_back(value(i, 3));
        }
        spec["t_s"] = t_s;
        spec["r_um"] = r;
        spec["y_um"] = y;
        spec["u_V"] = u;
        spec["window_start_s"] = static_cast<double>(log.tick(window_start)) / rate;
        const std::filesystem::path tmp = std::filesystem::path(a.plot).replace_extension(".plot.json");
        {
            std::ofstream f(tmp);
            f << spec.dump();
        }
        sim::run_plot_script(tmp);
        std::filesystem::remove(tmp);
    }

    std::string problems;
    if (stalled) problems += " log stalled (no frames for " + std::to_string(a.stall_s) + " s);";
    if (frames < want) problems += " " + std::to_string(want - frames) + " frames missing;";
    if (!ls.clean()) problems += " blocks lost/out of order/duplicated, tick gaps or recorder overruns;";
    if (!problems.empty()) {
        std::cerr << "error: record incomplete:" << problems << " see the summary\n";
        return 4;
    }
    return 0;
}

void add_record(CLI::App& app) {
    auto a = std::make_shared<RecordArgs>();
    CLI::App* cmd = app.add_subcommand(
        "record", "Record signals from the board to CSV; summary JSON with loss counts, metrics, log hash "
                  "(needs --device)");
    cmd->add_option("--signals", a->signals, "comma-separated: r, y, e, u, u_ff, u_fb, u_rc (default r,y,e,u)");
    cmd->add_option("--duration-s", a->duration_s, "device time to record")->required()->check(CLI::Range(1e-6, 1e5));
    cmd->add_option("--decimation", a->decimation, "keep every N-th tick")->check(CLI::Range(1, 1 << 24));
    cmd->add_flag("--start-wave", a->start_wave,
                  "start the trajectory with the recorder (and the loop, if disarmed) at the same tick");
    cmd->add_flag("--restart-stage", a->restart_stage,
                  "with --start-wave: emulated stage and loop from rest (a record equal to `piezoloop sim`)");
    cmd->add_option("--out", a->out, "CSV file: t_s and one column per signal with its unit");
    cmd->add_option("--plot", a->plot, "draw r, y, e and u to a PNG (tools/plot_sim.py)");
    cmd->add_option("--stall-s", a->stall_s, "give up when no frames arrive for this long")->check(CLI::Range(0.1, 3600.0));
    WaveRequest& w = a->w;
    auto* t = cmd->add_option("--trajectory", w.trajectory, "set this reference wave first (as `wave --no-start`)")
                  ->check(CLI::IsMember({"triangle", "sine", "square", "raster"}));
    cmd->add_option("--frequency-hz", w.frequency_Hz, "reference frequency")->check(CLI::Range(1e-4, 5e5));
    auto* amp = cmd->add_option("--amplitude-um", w.amplitude_um, "reference range, peak-to-peak (um)")
                    ->check(CLI::Range(1e-6, 1e3));
    cmd->add_option("--offset", w.offset, "unipolar | bipolar (default: the scenario's, else unipolar)")
        ->check(CLI::IsMember({"unipolar", "bipolar"}));
    cmd->add_option("--scenario", w.scenario, "take the offset convention from this scenario")->check(CLI::ExistingFile);
    cmd->add_option("--cycles", w.cycles, "periods the wave runs, 0 = forever");
    cmd->callback([a, t, amp] {
        int rc = 0;
        guarded([&] {
            a->wave_given = t->count() > 0 || amp->count() > 0;
            if (a->wave_given && !(a->w.amplitude_um > 0.0)) throw std::invalid_argument("--amplitude-um: required with --trajectory");
            rc = run_record(*a);
        });
        if (rc != 0) throw CLI::RuntimeError(rc);
    });
}

void add_device_commands(CLI::App& app) {
    add_status(app);
    add_get(app);
    add_set(app);
    add_arm(app);
    add_wave(app);
    add_stream(app);
    add_record(app);
}

const bool registered = register_command(60, add_device_commands);

}  // namespace
}  // namespace piezoloop::cli
