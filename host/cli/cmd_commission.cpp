// `piezoloop [--device ADDR] commission [--scenario S.json] --range-um R
// [--target-bandwidth-hz F] [--no-save] --out DIR`: a stage commissioned
// from measurements alone, on a board or on the simulator
// (cli/commission_session.hpp, host/commission/commission.hpp,
// docs/commissioning.md). Prints the summary JSON. Exit 2 for a bad request
// (nothing moved), 1 when a safety step stops it, no candidate passes or the
// verification fails (nothing saved; the report says why). The summary's
// wall_s is the whole run's wall time (the targets: <= 120 s on an
// emulated board, <= 20 s on the simulator).
#include <iostream>
#include <memory>
#include <optional>
#include <string>

#include "commands.hpp"
#include "commission_session.hpp"
#include "device_common.hpp"
#include "exit_codes.hpp"

namespace piezoloop::cli {
namespace {

struct CommissionArgs {
    CommissionSession session;
    bool no_save = false;
};

int run_commission(CommissionArgs a) {
    const bool on_board = a.session.scenario.empty();
    if (on_board && device_address().empty())
        throw std::invalid_argument("--scenario: give a scenario (simulator) or --device ADDR before `commission` (board)");
    if (!on_board && !device_address().empty())
        throw std::invalid_argument("--scenario: commissions the simulator; drop it to commission the board given by --device");
    if (!on_board && a.no_save) throw std::invalid_argument("--no-save: only on a board (--device)");
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
    cmd->add_option("--range-um", a->session.request.range_um, "travel the loop must hold (um)")->required();
    cmd->add_option("--target-bandwidth-hz", a->session.request.target_bandwidth_Hz,
                    "crossover to design for (default: a third of the first lightly damped mode, at most rate / 20)");
    cmd->add_flag("--no-save", a->no_save, "board: load and verify, but do not save the result on the board");
    cmd->add_option("--out", a->session.out, "directory for report.md and its figures, controller.json, frf.json, "
                                             "scenario.json")
        ->required();
    cmd->callback([a] { guarded([&] { return run_commission(*a); }); });
}

const bool registered = register_command(47, add_commission);

}  // namespace
}  // namespace piezoloop::cli
