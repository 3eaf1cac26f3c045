// Subcommands of the `piezoloop` command line. Each cli/cmd_*.cpp defines a
// function that adds its subcommand(s) to the app, and registers it with
//     const bool registered = register_command(<order>, add_xxx);
// at namespace scope; main() adds them in ascending order (the order of
// `piezoloop --help`). A command's failures are exceptions; guarded() (or
// main(), for anything that escapes) turns them into "error: ..." on stderr
// and the exit code of the policy in exit_codes.hpp.
#pragma once

#include <CLI/CLI.hpp>

#include <exception>
#include <iostream>
#include <type_traits>

#include "exit_codes.hpp"

namespace piezoloop::cli {

using AddCommand = void (*)(CLI::App&);

bool register_command(int order, AddCommand add);
void add_registered_commands(CLI::App& app);

// Runs a subcommand's body, which may return its exit code (0: ok); a
// failure is reported with the code of exit_codes.hpp's policy.
template <class F>
void guarded(F body) {
    int rc = 0;
    try {
        if constexpr (std::is_same_v<decltype(body()), void>) body();
        else rc = body();
    } catch (const std::exception& e) {
        rc = report_failure(e);
    }
    if (rc != 0) throw CLI::RuntimeError(rc);
}

}  // namespace piezoloop::cli
