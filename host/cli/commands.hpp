// Subcommands of the `piezoloop` command line. Each registers itself on the
// CLI11 app and runs when selected; errors go to stderr with a non-zero exit.
#pragma once

#include <CLI/CLI.hpp>

namespace piezoloop::cli {

void add_pi_inverse(CLI::App& app);
void add_demo(CLI::App& app);

}  // namespace piezoloop::cli
