// piezoloop: design, simulate and drive piezo servo controllers.
#include <CLI/CLI.hpp>

#include <algorithm>
#include <utility>
#include <vector>

#include "commands.hpp"
#include "device_common.hpp"
#include "exit_codes.hpp"

namespace piezoloop::cli {
namespace {

// Function-local static: safe to use from other files' static initialisers.
std::vector<std::pair<int, AddCommand>>& registry() {
    static std::vector<std::pair<int, AddCommand>> commands;
    return commands;
}

}  // namespace

bool register_command(int order, AddCommand add) {
    registry().emplace_back(order, add);
    return true;
}

void add_registered_commands(CLI::App& app) {
    auto commands = registry();
    std::stable_sort(commands.begin(), commands.end(),
                     [](const auto& a, const auto& b) { return a.first < b.first; });
    for (const auto& entry : commands) entry.second(app);
}

}  // namespace piezoloop::cli

int main(int argc, char** argv) {
    CLI::App app{"piezoloop: open digital servo controller for piezo nanopositioning stages"};
    app.require_subcommand(1);
    // The board the device subcommands (status, get, set, arm, wave, stream,
    // record, ...) talk to; given before the subcommand.
    app.add_option("--device", piezoloop::cli::device_address(),
                   "board to talk to: tcp:HOST:PORT (emulated, see `emulate`), usb, usb:SERIAL, "
                   "serial:PATH[@BAUD] (default: $PIEZOLOOP_DEVICE)")
        ->envname("PIEZOLOOP_DEVICE");
    piezoloop::cli::add_registered_commands(app);
    piezoloop::cli::require_finite_numbers(app);
    return piezoloop::cli::run_app(app, argc, argv);
}
