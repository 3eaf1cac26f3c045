// Subcommands of the `piezoloop` command line. Each cli/cmd_*.cpp defines a
// function that adds its subcommand(s) to the app, and registers it with
//     const bool registered = register_command(<order>, add_xxx);
// at namespace scope; main() adds them in ascending order (the order of
// `piezoloop --help`). Errors go to stderr with a non-zero exit
// (throw CLI::RuntimeError(code) from a callback).
#pragma once

#include <CLI/CLI.hpp>

#include <exception>
#include <iostream>
#include <stdexcept>

namespace piezoloop::cli {

using AddCommand = void (*)(CLI::App&);

bool register_command(int order, AddCommand add);
void add_registered_commands(CLI::App& app);

// Runs a subcommand's body: a bad input (std::invalid_argument from the
// libraries) prints "error: ..." and exits 2, any other failure exits 3.
template <class F>
void guarded(F body) {
    int rc = 0;
    try {
        body();
    } catch (const std::invalid_argument& e) {
        std::cerr << "error: " << e.what() << "\n";
        rc = 2;
    } catch (const std::exception& e) {
        std::cerr << "error: " << e.what() << "\n";
        rc = 3;
    }
    if (rc != 0) throw CLI::RuntimeError(rc);
}

}  // namespace piezoloop::cli
