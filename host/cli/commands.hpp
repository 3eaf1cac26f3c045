// Subcommands of the `piezoloop` command line. Each cli/cmd_*.cpp defines a
// function that adds its subcommand(s) to the app, and registers it with
//     const bool registered = register_command(<order>, add_xxx);
// at namespace scope; main() adds them in ascending order (the order of
// `piezoloop --help`). Errors go to stderr with a non-zero exit
// (throw CLI::RuntimeError(code) from a callback).
#pragma once

#include <CLI/CLI.hpp>

namespace piezoloop::cli {

using AddCommand = void (*)(CLI::App&);

bool register_command(int order, AddCommand add);
void add_registered_commands(CLI::App& app);

}  // namespace piezoloop::cli
