// `piezoloop sim`: one closed-loop run of a scenario case (configs/*.json)
// on the host, with the metrics (docs/models.md) of its last (steady-state) period as
// JSON on stdout. With --board-case FILE it also writes the run as a board
// case (common/piezoloop/board_case.hpp) for the QEMU boards' self-test,
// after clipping the case's limits to the boards' hard limits (and
// simulating that), or refuses (exit 2, naming the field) what the boards
// cannot run.
#include <unistd.h>

#include <algorithm>
#include <array>
#include <chrono>
#include <cmath>
#include <cstdint>
#include <cstdio>
#include <fstream>
#include <iostream>
#include <memory>
#include <optional>
#include <stdexcept>
#include <string>
#include <vector>

#include <nlohmann/json.hpp>

#include "commands.hpp"
#include "device_common.hpp"
#include "format/number.hpp"
#include "piezoloop/board_case.hpp"
#include "sim/build_case.hpp"
#include "sim/experiments.hpp"
#include "sim/model_dump.hpp"
#include "sim/multi_axis_sim_case.hpp"
#include "sim/plotting.hpp"
#include "sim/scenario.hpp"
#include "sim/sim_case.hpp"

namespace piezoloop::cli {
namespace {

struct SimArgs {
    std::string scenario;
    std::string case_name;
    std::string trajectory = "triangle";
    double frequency_Hz = 10.0;
    double amplitude_um = 0.0;
    double amplitude_V = 0.0;
    std::string offset;  // unipolar | bipolar (default: the scenario's)
    std::optional<double> midpoint_um;
    double duration_s = 0.0;
    std::string fidelity = "float";
    int substeps = 10;
    std::string sample;  // float | q31 (default: the case's)
    std::string out_csv;
    int log_every = 0;
    std::string plot;
    bool hash_only = false;
    bool list = false;
    std::string dump_model;
    std::string board_case;
    std::string axis;                // a stage of coupled axes: the axis that runs the wave
    std::vector<std::string> holds;  // --hold-um: NAME=UM, or UM for every held axis
    bool start_together = false;     // --start-together
};

// What a board case cannot carry: exit 2, the field named.
struct BoardCaseRefused : std::invalid_argument {
    BoardCaseRefused(const std::string& field, const std::string& why)
        : std::invalid_argument("--board-case: " + field + ": " + why) {}
};

// A progress bar on stderr, only on a terminal and only once a run has
// taken more than a second.
class SimProgress {
public:
    SimProgress() : tty_(isatty(STDERR_FILENO) != 0), t0_(std::chrono::steady_clock::now()) {}
    void update(double fraction) {
        if (!tty_) return;
        const double el = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0_).count();
        if (el < 1.0 && fraction < 1.0) return;
        if (el < 1.0 && !shown_) return;
        const int width = 40;
        const int filled = static_cast<int>(fraction * width + 0.5);
        std::string bar(static_cast<size_t>(filled), '#');
        bar.resize(width, ' ');
        const double eta = fraction > 0.0 ? el * (1.0 - fraction) / fraction : 0.0;
        std::fprintf(stderr, "\r[%s] %3.0f%%  %.1f s left ", bar.c_str(), 100.0 * fraction, eta);
        std::fflush(stderr);
        shown_ = true;
        if (fraction >= 1.0) std::fprintf(stderr, "\n");
    }

private:
    bool tty_;
    bool shown_ = false;
    std::chrono::steady_clock::time_point t0_;
};

// The run as the QEMU boards would make it: the case's limits clipped to
// their hard limits (as `set --scenario` clips them to a board's, the same
// code), the pipeline built with those hard limits; refuses what they lack.
void prepare_board_case(sim::BuiltCase& b, const sim::RunOptions& o, std::vector<std::string>& clipped) {
    sim::LoopModel& m = b.model;
    if (m.params.rc_enabled && m.params.rc.period_samples > kEmulatedBoardRcCapacity)
        throw BoardCaseRefused("rc.period_samples", std::to_string(m.params.rc.period_samples) +
                                                        " is beyond the boards' delay line of " +
                                                        std::to_string(kEmulatedBoardRcCapacity) +
                                                        " samples (raise --frequency-hz)");
    if (o.table.size() > link::kMaxWaveTable)
        throw BoardCaseRefused("trajectory.table", std::to_string(o.table.size()) + " points, the link carries at most " +
                                                       std::to_string(link::kMaxWaveTable));
    if (o.ticks > UINT32_MAX) throw BoardCaseRefused("ticks", "at most 2^32 - 1 ticks");
    link::HelloReply board;
    board.hard_u_min_V = kEmulatedBoardHardLimits.u_min_V;
    board.hard_u_max_V = kEmulatedBoardHardLimits.u_max_V;
    board.hard_slew_max_V_per_s = kEmulatedBoardHardLimits.slew_max_V_per_s;
    m.params.limits = clip_to_hard_limits(link::LimitsParams{m.params.limits}, board, clipped).limits;
    m.setup.hard = kEmulatedBoardHardLimits;
    for (const std::string& t : clipped) std::cerr << "clipped: " << t << "\n";
}

void write_board_case(const std::string& file, const sim::Scenario& s, const sim::CaseSpec& c,
                      const sim::BuiltCase& b, const sim::RunOptions& o) {
    const sim::LoopModel& m = b.model;
    BoardCase bc;
    const std::string name = s.name + "/" + c.name;
    if (name.size() >= kBoardCaseNameBytes)
        throw BoardCaseRefused("name", "'" + name + "' is longer than " + std::to_string(kBoardCaseNameBytes - 1));
    std::copy(name.begin(), name.end(), bc.name.begin());
    bc.ticks = static_cast<uint32_t>(o.ticks);
    bc.metric_start_tick = static_cast<uint32_t>(o.window_start);
    bc.sample = m.sample == sim::SampleType::kQ31 ? link::SampleFormat::kQ31 : link::SampleFormat::kFloat32;
    const double rate = std::round(static_cast<double>(m.setup.rate_Hz));
    if (rate != static_cast<double>(m.setup.rate_Hz) || rate < 1.0)
        throw BoardCaseRefused("loop.rate_Hz", "must be a whole number of Hz");
    bc.profile.loop_rate_Hz = static_cast<uint32_t>(rate);
    bc.profile.position_full_scale_um = m.setup.position.full_scale;
    bc.profile.voltage_full_scale_V = m.setup.voltage.full_scale;
    bc.profile.stage = m.stage;
    bc.profile.stage.rate_Hz = m.setup.rate_Hz;
    if (const Status st = validate(bc.profile); !st.ok())
        throw BoardCaseRefused(std::string(st.group != nullptr ? st.group : "profile") + "." + st.field, st.message);
    bc.params = m.params;
    link::TrajectoryParams& t = bc.trajectory;
    t.waveform = o.wave.waveform;
    t.amplitude_um = o.wave.amplitude_um;
    t.offset_um = o.wave.offset_um;
    t.frequency_Hz = o.wave.frequency_Hz;
    t.cycles = o.wave.cycles;
    t.start_phase_cycles = o.wave.start_phase_cycles;
    t.return_fraction = o.wave.return_fraction;
    t.duty = o.wave.duty;
    t.table_count = static_cast<uint16_t>(o.table.size());
    std::copy(o.table.begin(), o.table.end(), t.table.begin());
    std::array<uint8_t, kBoardCaseSlotBytes> bytes{};
    const std::size_t n = encode_board_case(bc, bytes);
    if (n == 0) throw BoardCaseRefused("length", "the case does not fit a 2048-byte slot");
    // What the board will decode must be what was simulated.
    BoardCase back;
    if (const Status st = decode_board_case(std::span<const uint8_t>(bytes.data(), n), back); !st.ok())
        throw BoardCaseRefused(st.field, st.message);
    std::ofstream f(file, std::ios::binary);
    if (!f) throw std::runtime_error("--board-case: cannot write " + file);
    f.write(reinterpret_cast<const char*>(bytes.data()), static_cast<std::streamsize>(n));
    if (!f) throw std::runtime_error("--board-case: cannot write " + file);
}

sim::SimCaseRequest sim_request(const SimArgs& a) {
    sim::SimCaseRequest req;
    req.case_name = a.case_name;
    req.trajectory = a.trajectory;
    req.frequency_Hz = a.frequency_Hz;
    req.amplitude_um = a.amplitude_um;
    req.amplitude_V = a.amplitude_V;
    req.offset = a.offset;
    req.midpoint_um = a.midpoint_um;
    req.duration_s = a.duration_s;
    req.fidelity = a.fidelity;
    req.substeps = a.substeps;
    req.sample = a.sample;
    req.log = !a.out_csv.empty() || !a.plot.empty();
    req.log_every = a.log_every;
    return req;
}

// A stage of coupled axes: one axis runs the wave, the others hold
// (sim/multi_axis_sim_case.hpp). The CSV holds, per tick, every axis's
// r, y, channel command and true position.
int run_multi_axis(const SimArgs& a, const sim::Scenario& s) {
    const std::string axes = " (a stage of coupled axes has " + std::to_string(s.axes.size()) + ")";
    if (!a.board_case.empty()) throw std::invalid_argument("--board-case: the boards run one axis" + axes);
    if (!a.dump_model.empty()) throw std::invalid_argument("--dump-model: one axis only" + axes);
    if (!a.plot.empty()) throw std::invalid_argument("--plot: one axis only (write --out and plot its columns)");
    sim::MultiAxisSimRequest req;
    req.sim = sim_request(a);
    req.axis = a.axis;
    req.holds = a.holds;
    req.start_together = a.start_together;
    // --hash prints no notes: the controllers' realisation check is skipped.
    req.check_realisation = !a.hash_only;
    const sim::MultiAxisSimPlan plan = sim::plan_multi_axis_sim(s, req);
    const sim::MultiAxisRunResult r = sim::run_multi_axis(plan.model, plan.options);
    if (a.hash_only) {
        std::cout << format::hex64(r.log_hash) << "\n";
    } else {
        std::cout << sim::multi_axis_sim_summary(s, req, plan, r).dump(1) << "\n";
    }
    if (!a.out_csv.empty()) {
        std::ofstream f(a.out_csv);
        if (!f) throw std::runtime_error("--out: cannot write " + a.out_csv);
        const std::vector<std::string>& names = plan.model.names;
        f << "tick,t_s";
        for (const std::string& n : names) f << ",r_" << n << "_um,y_" << n << "_um,u_" << n << "_V,p_" << n << "_um";
        f << "\n";
        const sim::MultiAxisLog& l = r.log;
        auto cell = [](double v) { return "," + format::significant(v, 9); };
        for (size_t k = 0; k < l.tick.size(); ++k) {
            f << l.tick[k] << cell(static_cast<double>(l.tick[k]) / s.rate_Hz);
            for (size_t i = 0; i < names.size(); ++i)
                f << cell(l.r_um[i][k]) << cell(l.y_um[i][k]) << cell(l.u_V[i][k]) << cell(l.p_um[i][k]);
            f << "\n";
        }
    }
    return 0;
}

int run(const SimArgs& a) {
    const sim::Scenario s = sim::load_scenario(a.scenario);
    if (!a.list && s.multi_axis()) return run_multi_axis(a, s);
    if (!a.axis.empty()) throw std::invalid_argument("--axis: the scenario's stage has one axis (leave --axis out)");
    if (!a.holds.empty()) throw std::invalid_argument("--hold-um: the scenario's stage has one axis (leave --hold-um out)");
    if (a.start_together) throw std::invalid_argument("--start-together: the scenario's stage has one axis");
    if (a.list) {
        nlohmann::json out;
        out["scenario"] = s.name;
        for (const sim::AxisSpec& x : s.axes) out["axes"].push_back(x.name);
        for (const sim::CaseSpec& c : s.cases) out["cases"].push_back({{"name", c.name}, {"label", c.label}});
        for (const sim::ExperimentSpec& e : s.experiments)
            out["experiments"].push_back({{"name", e.name}, {"kind", e.kind}, {"title", e.title}});
        std::cout << out.dump(1) << "\n";
        return 0;
    }
    if (!a.board_case.empty()) {
        // Checked before the case is built, as the trajectory options are.
        if (a.case_name.empty()) throw std::invalid_argument("--case: required (see --list)");
        (void)s.find_case(a.case_name);
        if (a.fidelity != "float")
            throw BoardCaseRefused("fidelity", "the boards run the float stage model (--fidelity float)");
    }
    const sim::SimCaseRequest req = sim_request(a);
    sim::SimCasePlan plan = sim::plan_sim_case(s, req);
    const sim::CaseSpec& c = plan.case_spec;
    const sim::TrajectoryRequest& t = plan.trajectory;
    sim::BuiltCase& b = plan.built;
    sim::RunOptions& o = plan.options;
    std::vector<std::string> clipped;
    if (!a.board_case.empty()) prepare_board_case(b, o, clipped);
    auto progress = std::make_shared<SimProgress>();
    o.progress = [progress](double f) { progress->update(f); };
    const sim::RunResult r = sim::run_loop(b.model, o);

    if (!a.dump_model.empty()) {
        if (o.fidelity != sim::Fidelity::kFloat)
            throw std::invalid_argument("--dump-model: only the float fidelity can be replayed");
        sim::ModelDump d;
        d.setup = b.model.setup;
        d.params = b.model.params;
        d.q31 = b.model.sample == sim::SampleType::kQ31 ? 1u : 0u;
        d.stage = b.model.stage;
        d.stage.rate_Hz = b.model.setup.rate_Hz;
        d.wave = o.wave;
        d.wave.sample_rate_Hz = b.model.setup.rate_Hz;
        d.table = o.table;
        d.ticks = o.ticks;
        const std::vector<unsigned char> bytes = sim::serialise(d);
        std::ofstream f(a.dump_model, std::ios::binary);
        if (!f) throw std::runtime_error("--dump-model: cannot write " + a.dump_model);
        f.write(reinterpret_cast<const char*>(bytes.data()), static_cast<std::streamsize>(bytes.size()));
    }

    if (!a.board_case.empty()) write_board_case(a.board_case, s, c, b, o);

    if (a.hash_only) {
        std::cout << format::hex64(r.log_hash) << "\n";
    } else {
        nlohmann::json out = sim::sim_case_summary(s, req, plan, r);
        if (!a.board_case.empty()) out["board_case"] = {{"file", a.board_case}, {"clipped", clipped}};
        std::cout << out.dump(1) << "\n";
    }

    if (!a.out_csv.empty()) {
        std::ofstream f(a.out_csv);
        if (!f) throw std::runtime_error("--out: cannot write " + a.out_csv);
        f << "tick,t_s,r_um,y_um,e_um,u_V,u_ff_V,u_fb_V,v_piezo_V,x_um\n";
        const sim::RunLog& l = r.log;
        // 9 significant digits: the float samples round-trip.
        auto cell = [](double v) { return "," + format::significant(v, 9); };
        for (size_t i = 0; i < l.tick.size(); ++i) {
            f << l.tick[i] << cell(static_cast<double>(l.tick[i]) / s.rate_Hz) << cell(l.r_um[i]) << cell(l.y_um[i])
              << cell(l.r_um[i] - l.y_um[i]) << cell(l.u_V[i]) << cell(l.u_ff_V[i]) << cell(l.u_fb_V[i])
              << cell(l.v_piezo_V[i]) << cell(l.x_um[i]) << "\n";
        }
    }
    if (!a.plot.empty()) {
        nlohmann::json spec;
        spec["kind"] = "sim";
        spec["output"] = std::filesystem::absolute(a.plot).string();
        spec["title"] = s.name + ": " + c.label + ", " + a.trajectory + " " + format::significant(a.frequency_Hz) +
                        " Hz, " + format::significant(t.range_um) + " um p-p (" + sim::to_string(o.fidelity) +
                        " fidelity)";
        const sim::RunLog& l = r.log;
        nlohmann::json t_s = nlohmann::json::array();
        for (const uint64_t k : l.tick) t_s.push_back(static_cast<double>(k) / s.rate_Hz);
        spec["t_s"] = t_s;
        spec["r_um"] = l.r_um;
        spec["y_um"] = l.y_um;
        spec["u_V"] = l.u_V;
        spec["window_start_s"] = static_cast<double>(o.window_start) / s.rate_Hz;
        sim::plot_spec("plot_sim.py", spec);
    }
    return 0;
}

}  // namespace

void add_sim(CLI::App& app) {
    auto a = std::make_shared<SimArgs>();
    CLI::App* cmd = app.add_subcommand(
        "sim", "Closed-loop simulation of a scenario case: metrics of the last period as JSON");
    cmd->add_option("--scenario", a->scenario, "scenario file (configs/*.json)")->required()->check(CLI::ExistingFile);
    cmd->add_option("--case", a->case_name, "controller case of the scenario (see --list)");
    cmd->add_flag("--list", a->list, "list the scenario's cases and experiments");
    // The ranges and choices are checked by sim::check_sim_request, as the
    // Python module's piezoloop.sim checks them.
    cmd->add_option("--trajectory", a->trajectory, "reference waveform: triangle | sine");
    cmd->add_option("--frequency-hz", a->frequency_Hz, "reference frequency, 1e-4 to 5e5 Hz");
    cmd->add_option("--amplitude-um", a->amplitude_um, "reference range, peak-to-peak, 1e-6 to 1e3 um");
    cmd->add_option("--amplitude-v", a->amplitude_V,
                    "reference range as peak-to-peak piezo voltage, 1e-6 to 1e4 V, converted at the stage's mean "
                    "slope");
    cmd->add_option("--offset", a->offset, "unipolar: from 0 up; bipolar: centred on 0 (default: the scenario's)");
    cmd->add_option("--midpoint-um", a->midpoint_um, "the wave's midpoint, -1e3 to 1e3 um (instead of --offset's)");
    cmd->add_option("--duration-s", a->duration_s,
                    "simulated time, 1e-6 to 1e4 s (default two periods; the last full period is measured)");
    cmd->add_option("--fidelity", a->fidelity, "float: the boards' stage model; double: continuous sub-steps");
    cmd->add_option("--substeps", a->substeps, "double fidelity: sub-steps per tick, 1 to 10000");
    cmd->add_option("--sample", a->sample, "core sample type: float | q31 (default: the case's)");
    cmd->add_option("--out", a->out_csv, "write the log as CSV");
    cmd->add_option("--log-every", a->log_every, "log every N-th tick, 1 to 2^30 (default: at most 200000 rows)");
    cmd->add_option("--plot", a->plot, "draw r, y, e and the loop to a PNG (tools/plot_sim.py)");
    cmd->add_option("--dump-model", a->dump_model,
                    "write the run's core parameters as raw bytes (for tests/host/sim/sim_hash_probe, float fidelity)");
    cmd->add_option("--board-case", a->board_case,
                    "also write this run as a board case for the QEMU boards' self-test (limits clipped to their "
                    "hard limits and simulated so; docs/boards.md, Self-test)");
    cmd->add_option("--axis", a->axis,
                    "a stage of coupled axes: the axis that runs the reference (by name); the others hold");
    cmd->add_option("--hold-um", a->holds,
                    "a stage of coupled axes: NAME=UM, a held axis's setpoint (repeatable), or UM for every held "
                    "axis (default: the wave's first value)");
    cmd->add_flag("--start-together", a->start_together,
                  "a stage of coupled axes: the driven wave starts at tick 0 beside the held axes' approaches (as a "
                  "board's `record --start-wave --every-axis`), not after them");
    cmd->add_flag("--hash", a->hash_only, "print only the log hash of r, y, u (compare with the board self-test)");
    cmd->callback([a] {
        guarded([&] { return run(*a); });
    });
}

namespace {
const bool registered_sim = register_command(40, add_sim);
}  // namespace

}  // namespace piezoloop::cli
