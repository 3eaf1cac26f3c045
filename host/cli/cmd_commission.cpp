// `piezoloop [--device ADDR] commission [--scenario S.json] --range-um R
// [--target-bandwidth-hz F] [--no-save] --out DIR`: a stage commissioned
// from measurements alone, on a board or on the simulator
// (cli/commission_session.hpp, host/commission/commission.hpp,
// docs/commissioning.md). Prints the summary JSON. Exit 2 for a bad request
// (nothing moved), 1 when a safety step stops it, no candidate passes or the
// verification fails (nothing saved; the report says why). The summary's
// wall_s is the whole run's wall time (the targets: <= 120 s on an
// emulated board, <= 20 s on the simulator). With --axes, a scenario's
// coupled axes one by one and then decoupled (cli/commission_axes.hpp).
#include <cmath>
#include <cstdlib>
#include <iostream>
#include <memory>
#include <optional>
#include <sstream>
#include <string>
#include <vector>

#include "commands.hpp"
#include "commission_axes.hpp"
#include "commission_session.hpp"
#include "device_common.hpp"
#include "exit_codes.hpp"

namespace piezoloop::cli {
namespace {

struct CommissionArgs {
    CommissionSession session;
    std::string range;  // UM, or NAME=UM,... per axis (--axes)
    std::string axes;   // x,y[,z] or all: a stage of coupled axes
    bool no_save = false;
};

double range_number(const std::string& text) {
    char* end = nullptr;
    const double v = std::strtod(text.c_str(), &end);
    if (text.empty() || end != text.c_str() + text.size() || !std::isfinite(v))
        throw std::invalid_argument("--range-um: must be a number of um (or NAME=UM,... per axis with --axes), got '" +
                                    text + "'");
    return v;
}

std::vector<std::string> split(const std::string& text) {
    std::vector<std::string> parts;
    std::stringstream in(text);
    for (std::string p; std::getline(in, p, ',');) parts.push_back(p);
    return parts;
}

// The board (--device) or the simulator (--scenario), one of the two;
// true: the board.
bool commission_on_board(const CommissionArgs& a) {
    const bool on_board = a.session.scenario.empty();
    if (on_board && device_address().empty())
        throw std::invalid_argument("--scenario: give a scenario (simulator) or --device ADDR before `commission` (board)");
    if (!on_board && !device_address().empty())
        throw std::invalid_argument("--scenario: commissions the simulator; drop it to commission the board given by --device");
    if (!on_board && a.no_save) throw std::invalid_argument("--no-save: only on a board (--device)");
    return on_board;
}

// --axes x,y,z with --range-um UM (every axis) or x=UM,y=UM,z=UM.
int run_axes(const CommissionArgs& a) {
    const bool on_board = commission_on_board(a);
    AxesCommission c;
    c.scenario = a.session.scenario;
    c.out = a.session.out;
    c.request = a.session.request;
    c.axes = split(a.axes);
    if (a.range.find('=') == std::string::npos) {
        c.range_every_um = range_number(a.range);
    } else {
        for (const std::string& item : split(a.range)) {
            const std::size_t eq = item.find('=');
            if (eq == std::string::npos)
                throw std::invalid_argument("--range-um: NAME=UM for every axis, got '" + item + "'");
            c.range_um[item.substr(0, eq)] = range_number(item.substr(eq + 1));
        }
    }
    auto say = [](const std::string& line) { std::cerr << "commission: " << line << "\n"; };
    const StopSignals stop_signals;
    std::optional<hostlink::Client> board;
    if (on_board) board.emplace(open_device());
    const nlohmann::json out = interruptible("commission", [&] {
        return board ? run_axes_commission_board(*board, c, !a.no_save, say, [] { return StopSignals::requested(); })
                     : run_axes_commission(c, say, [] { return StopSignals::requested(); });
    });
    std::cout << out.dump(1) << "\n";
    return out["verified"].get<bool>() ? kExitOk : kExitFailure;
}

int run_commission(CommissionArgs a) {
    if (!a.axes.empty() && !a.session.axis.empty())
        throw std::invalid_argument("--axis: not with --axes (a scenario's axes, each commissioned)");
    if (!a.axes.empty()) return run_axes(a);
    a.session.request.range_um = range_number(a.range);
    const bool on_board = commission_on_board(a);
    if (!on_board && !a.session.axis.empty())
        throw std::invalid_argument("--axis: a board's axis; a scenario's coupled axes are commissioned with --axes");
    a.session.save = !a.no_save;
    auto say = [](const std::string& line) { std::cerr << "commission: " << line << "\n"; };
    std::optional<hostlink::Client> board;
    std::optional<StopSignals> stop_signals;
    if (on_board) {
        board.emplace(open_device());
        stop_signals.emplace();
    }
    const nlohmann::json out = interruptible("commission", [&] {
        return run_commission_session(board ? &*board : nullptr, a.session, say,
                                      [] { return StopSignals::requested(); });
    });
    std::cout << out.dump(1) << "\n";
    return out["verified"].get<bool>() ? kExitOk : kExitFailure;
}

void add_commission(CLI::App& app) {
    auto a = std::make_shared<CommissionArgs>();
    CLI::App* cmd = app.add_subcommand(
        "commission", "Commission a stage from measurements alone, on the board given by --device or a simulated "
                      "stage: safety steps, frequency response, hysteresis loop, model fits, a robust and a classic "
                      "candidate checked on the measurement, the best predicted loaded, verified and saved "
                      "(docs/commissioning.md)");
    cmd->add_option("--scenario", a->session.scenario,
                    "simulator: the scenario whose stage is measured (open loop); without it, the board (--device)")
        ->check(CLI::ExistingFile);
    cmd->add_option("--range-um", a->range,
                    "travel the loop must hold (um); with --axes one for every axis or NAME=UM,... each")
        ->required();
    cmd->add_option("--axes", a->axes,
                    "coupled axes (a scenario's or the --device board's): x,y[,z] (every axis) or all; each "
                    "commissioned, then decoupled");
    cmd->add_option("--axis", a->session.axis,
                    "a board of axes: x | y | z, the axis commissioned (default: the only axis; required on a "
                    "multi-axis board); the others hold with their own controllers");
    cmd->add_option("--target-bandwidth-hz", a->session.request.target_bandwidth_Hz,
                    "crossover to design for (default: a third of the first lightly damped mode, at most rate / 20)");
    cmd->add_flag("--no-save", a->no_save, "board: load and verify, but do not save the result on the board");
    cmd->add_option("--out", a->session.out, "directory for report.md and its figures, controller.json, frf.json, "
                                             "scenario.json")
        ->required();
    cmd->callback([a] { guarded([&] { return run_commission(*a); }); });
}

const bool registered_commission = register_command(47, add_commission);

}  // namespace
}  // namespace piezoloop::cli
