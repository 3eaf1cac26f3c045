// `piezoloop ui`: the browser console (host/ui/, docs/console.md): a local
// web server with the board's live scope, status, controls and parameter
// forms, on the --device board or, with --scenario, on an emulated board
// started for it (`piezoloop emulate` with the scenario's stage, and the
// case's controller when --case is given).
#include <signal.h>
#include <arpa/inet.h>
#include <spawn.h>
#include <sys/wait.h>
#include <unistd.h>

#include <cstdio>
#include <iostream>
#include <memory>
#include <optional>
#include <string>
#include <vector>

#include <nlohmann/json.hpp>

#include "commands.hpp"
#include "device_common.hpp"
#include "ui/board_session.hpp"
#include "ui/console_server.hpp"

extern char** environ;

namespace piezoloop::cli {
namespace {

struct UiArgs {
    std::string scenario, case_name, board = "qemu-m7", bind = "127.0.0.1";
    int port = 0;
    bool open = false;
    double history_s = 20.0;
    int seat_answer_s = 10;
};

// `piezoloop emulate` as a child process: its board address, stopped with
// SIGTERM (it then stops its QEMU) when this ends.
class EmulatedBoard {
public:
    EmulatedBoard(const UiArgs& a) {
        int fds[2];
        if (pipe(fds) != 0) throw std::runtime_error("cannot create a pipe for the emulated board");
        posix_spawn_file_actions_t actions;
        posix_spawn_file_actions_init(&actions);
        posix_spawn_file_actions_adddup2(&actions, fds[1], STDOUT_FILENO);
        posix_spawn_file_actions_addclose(&actions, fds[0]);
        std::vector<std::string> args = {"piezoloop", "emulate", "--board", a.board, "--scenario", a.scenario};
        if (!a.case_name.empty()) args.insert(args.end(), {"--case", a.case_name});
        std::vector<char*> argv;
        for (auto& s : args) argv.push_back(s.data());
        argv.push_back(nullptr);
        const int rc = posix_spawn(&pid_, "/proc/self/exe", &actions, nullptr, argv.data(), environ);
        posix_spawn_file_actions_destroy(&actions);
        close(fds[1]);
        if (rc != 0) {
            close(fds[0]);
            throw std::runtime_error("cannot start `piezoloop emulate`");
        }
        FILE* out = fdopen(fds[0], "r");
        std::string line;
        for (int ch; (ch = std::fgetc(out)) != EOF && ch != '\n';) line += static_cast<char>(ch);
        std::fclose(out);
        const auto j = nlohmann::json::parse(line, nullptr, false);
        if (j.is_discarded() || !j.contains("device"))
            throw hostlink::LinkError("the emulated board did not start (see `piezoloop emulate` above)");
        address_ = j["device"].get<std::string>();
    }
    ~EmulatedBoard() {
        if (pid_ > 0) {
            kill(pid_, SIGTERM);
            int status = 0;
            waitpid(pid_, &status, 0);
        }
    }
    EmulatedBoard(const EmulatedBoard&) = delete;
    EmulatedBoard& operator=(const EmulatedBoard&) = delete;
    const std::string& address() const { return address_; }

private:
    pid_t pid_ = -1;
    std::string address_;
};

void open_in_browser(const std::string& url) {
    pid_t pid = 0;
    std::string prog = "xdg-open", arg = url;
    char* argv[] = {prog.data(), arg.data(), nullptr};
    if (posix_spawnp(&pid, "xdg-open", nullptr, nullptr, argv, environ) != 0)
        std::cerr << "note: could not run xdg-open; open the URL yourself\n";
}

int run_ui(const UiArgs& a) {
    // Checked before anything starts: an address the listener could not use.
    in_addr v4{};
    in6_addr v6{};
    if (a.bind != "localhost" && inet_pton(AF_INET, a.bind.c_str(), &v4) != 1 &&
        inet_pton(AF_INET6, a.bind.c_str(), &v6) != 1)
        throw std::invalid_argument("--bind: " + a.bind +
                                    " is not an IPv4 or IPv6 address (e.g. 127.0.0.1, 0.0.0.0 for every network, ::)");
    const bool wildcard = a.bind == "0.0.0.0" || a.bind == "::";
    if (a.bind != "127.0.0.1" && a.bind != "localhost") {
        std::cerr << "\n*** WARNING: --bind " << a.bind << ": the console is reachable from "
                  << (wildcard ? "every network this machine is on" : "the network of " + a.bind)
                  << ", over unencrypted HTTP.\n*** Anyone who sees the token (in the URL, on the network) can drive "
                     "the stage. Use it only on a network you trust.\n\n";
    }
    std::optional<EmulatedBoard> emulated;
    if (!a.scenario.empty()) {
        if (!device_address().empty()) throw std::invalid_argument("give either --device or --scenario, not both");
        emulated.emplace(a);
        device_address() = emulated->address();
    } else if (!a.case_name.empty()) {
        throw std::invalid_argument("--case needs --scenario");
    }
    hostlink::Client client = open_device(5000);
    if (emulated && !a.case_name.empty())
        send_scenario_case(client, a.scenario, a.case_name, 0.0, [](const std::string& l) { std::cerr << l << "\n"; });
    ui::BoardSession board(std::move(client), a.history_s);
    board.start();
    ui::ConsoleOptions o;
    o.bind_address = a.bind;
    o.port = a.port;
    o.scenario = a.scenario;
    o.seat_answer_s = a.seat_answer_s;
    ui::ConsoleServer server(board, o);
    const int port = server.bind();
    std::string url = server.url();
    std::cout << "piezoloop ui: the console of " << board.address() << " at\n  " << url << "\n";
    if (!wildcard && a.bind != "127.0.0.1" && a.bind != "localhost") {
        std::string remote = url;
        remote.replace(remote.find("127.0.0.1"), 9, a.bind);
        std::cout << "  " << remote << "\n";
    }
    std::cout << "(port " << port << "; Ctrl-C stops the console, the board keeps running)" << std::endl;
    if (a.open) open_in_browser(url);
    const StopSignals stop_signals;
    server.serve([] { return StopSignals::requested(); });
    board.stop();
    return kExitOk;
}

void add_ui(CLI::App& app) {
    auto a = std::make_shared<UiArgs>();
    CLI::App* cmd = app.add_subcommand(
        "ui", "The browser console: live scope, status, arm/disarm/stop, parameter forms and waves of the --device "
              "board (or of an emulated board with --scenario) in a local web page");
    cmd->add_option("--scenario", a->scenario,
                    "start an emulated board with this scenario's stage (`piezoloop emulate`) instead of --device")
        ->check(CLI::ExistingFile);
    cmd->add_option("--case", a->case_name, "with --scenario: load this case's controller and limits on it");
    cmd->add_option("--board", a->board, "with --scenario: qemu-m7 (float core) or qemu-m3 (Q31 core)")
        ->check(CLI::IsMember({"qemu-m7", "qemu-m3"}));
    cmd->add_option("--port", a->port, "TCP port of the console (default: a free one)")->check(CLI::Range(1, 65535));
    cmd->add_option("--bind", a->bind,
                    "address to listen on (default 127.0.0.1: this machine only; anything else is reachable from "
                    "the network)");
    cmd->add_option("--history-s", a->history_s, "seconds of the board's signals kept for the scope, 1 to 600")
        ->check(CLI::Range(1.0, 600.0));
    cmd->add_option("--seat-answer-s", a->seat_answer_s,
                    "seconds the controlling page has to answer another page's request for control before it "
                    "passes, 1 to 600 (default 10)")
        ->check(CLI::Range(1, 600));
    cmd->add_flag("--open", a->open, "open the console in the default browser (xdg-open)");
    cmd->callback([a] { guarded([&] { return run_ui(*a); }); });
}

const bool registered_ui = register_command(62, add_ui);

}  // namespace
}  // namespace piezoloop::cli
