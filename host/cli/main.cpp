// piezoloop: design, simulate and drive piezo servo controllers.
#include <CLI/CLI.hpp>

#include "commands.hpp"

int main(int argc, char** argv) {
    CLI::App app{"piezoloop: open digital servo controller for piezo nanopositioning stages"};
    app.require_subcommand(1);
    piezoloop::cli::add_pi_inverse(app);
    piezoloop::cli::add_demo(app);

    CLI11_PARSE(app, argc, argv);
    return 0;
}
