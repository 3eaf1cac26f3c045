// The exit-code policy of every `piezoloop` command, in one place (README.md,
// "Exit codes"):
//   0 ok, 1 other failure, 2 bad input (options, files, values),
//   3 link or device, 4 lost data.
// Commands signal failures by throwing; main() turns the exception into
// "error: ..." on stderr and the code:
//   std::invalid_argument and CLI11's option errors  -> 2
//   hostlink::LinkError (transport, device refusals) -> 3
//   LostData (an incomplete record; a board session
//   interrupted by Ctrl-C, device_common's interruptible) -> 4
//   anything else (a file not writable, a plot that failed, a bug) -> 1
#pragma once

#include <CLI/CLI.hpp>

#include <exception>
#include <stdexcept>
#include <string>
#include <vector>

namespace piezoloop::cli {

enum ExitCode : int {
    kExitOk = 0,
    kExitFailure = 1,
    kExitBadInput = 2,
    kExitLinkOrDevice = 3,
    kExitLostData = 4,
};

// A run that finished but lost data (an incomplete record or stream); the
// summary was printed already.
struct LostData : std::runtime_error {
    using std::runtime_error::runtime_error;
};

// The code of a failure (the policy above).
int exit_code_of(const std::exception& e);

// Prints "error: <what>" to stderr and returns its exit code.
int report_failure(const std::exception& e);

// Parses argv and runs the chosen command; returns the process's exit code.
int run_app(CLI::App& app, int argc, char** argv);

// Every floating-point option of app and its subcommands (found by CLI11's
// type name FLOAT) refuses NaN and +-inf: "--name: must be a finite number".
void require_finite_numbers(CLI::App& app);

// A comma-separated list of numbers (a,b,c) as one option, read by
// parse_number_list (option_checks.hpp): an empty item ("1,,2"), text or a
// non-finite number is refused naming the option and the item (CLI11's
// delimiter would drop the empty item silently).
template <class T>
CLI::Option* add_number_list(CLI::App* cmd, const std::string& name, std::vector<T>& out, const std::string& help);

}  // namespace piezoloop::cli
