// `piezoloop emulate`: an emulated board in QEMU (servo.elf on mps2-an500 /
// mps2-an385) with a scenario's stage loaded as its emulation profile (a
// stage of coupled axes with the axes blob beside it), the
// link on a local TCP port, and with --storage a host file as the board's
// parameter storage (docs/storage.md); `piezoloop devices`: the USB boards attached and
// how to start an emulated one.
#include <fcntl.h>
#include <netinet/in.h>
#include <signal.h>
#include <spawn.h>
#include <sys/socket.h>
#include <sys/wait.h>
#include <unistd.h>

#include <chrono>
#include <cmath>
#include <csignal>
#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <iostream>
#include <memory>
#include <optional>
#include <span>
#include <string>
#include <thread>
#include <vector>

#include <nlohmann/json.hpp>

#include "commands.hpp"
#include "device_common.hpp"
#include "link/tcp_transport.hpp"
#include "piezoloop/axes/emulation_axes_profile.hpp"
#include "piezoloop/emulation_profile.hpp"
#include "sim/build_case.hpp"
#include "sim/coupled_stage_build.hpp"
#include "status_text.hpp"

extern char** environ;

namespace piezoloop::cli {
namespace {

namespace fs = std::filesystem;
using nlohmann::json;

struct EmulateArgs {
    std::string board = "qemu-m7";
    std::string scenario, case_name;
    int port = 0;
    std::string image;
    std::string storage;
    double boot_timeout_s = 20.0;
};

// Longest storage path: the firmware reads it from the semihosting command
// line into a 256-byte buffer, with ".new" appended for the atomic replace
// (bsp/mps2/semihosting_storage.cpp).
constexpr std::size_t kMaxStoragePath = 200;

// What a path names, for the refusal of anything but a regular file.
const char* file_kind(fs::file_type t) {
    switch (t) {
        case fs::file_type::directory: return "a directory";
        case fs::file_type::character: return "a character device";
        case fs::file_type::block: return "a block device";
        case fs::file_type::fifo: return "a FIFO";
        case fs::file_type::socket: return "a socket";
        default: return "not a regular file";
    }
}

// The storage file as an absolute path (QEMU's working directory does not
// matter then), created empty when missing: an empty file is an empty
// storage. A save writes PATH.new beside it and renames that over PATH, so
// PATH must be a regular file (a device node, a FIFO or a directory would
// be replaced, or block the board's first read), writable, in a writable
// folder; a link is followed to the file it names. Checked without opening
// anything that is not a regular file (opening a FIFO blocks).
fs::path storage_file(const std::string& arg) {
    const auto refuse = [](const fs::path& p, const std::string& why) {
        throw std::invalid_argument("--storage: " + p.string() + " " + why);
    };
    fs::path p = fs::absolute(arg).lexically_normal();
    std::error_code ec;
    if (fs::is_symlink(fs::symlink_status(p, ec))) {
        p = fs::weakly_canonical(p, ec);
        if (ec) refuse(p, "is a link that cannot be followed: " + ec.message());
    }
    const fs::file_status st = fs::status(p, ec);
    if (fs::exists(st)) {
        if (!fs::is_regular_file(st))
            refuse(p, std::string("is ") + file_kind(st.type()) + ": the storage must be a regular file (or a new one)");
        // Root may write a read-only file; its mode still says not to.
        if ((st.permissions() & fs::perms::owner_write) == fs::perms::none || ::access(p.c_str(), W_OK) != 0)
            refuse(p, "is read-only: the storage must be writable");
    } else {
        if (!fs::is_directory(p.parent_path())) refuse(p, "is in a folder that does not exist");
        std::ofstream create(p, std::ios::binary | std::ios::app);
        if (!create) refuse(p, "cannot be created");
    }
    if (::access(p.parent_path().c_str(), W_OK) != 0)
        refuse(p, "is in a folder that is not writable (a save writes " + p.filename().string() + ".new beside it)");
    if (p.string().size() > kMaxStoragePath)
        throw std::invalid_argument("--storage: the absolute path " + p.string() + " is longer than " +
                                    std::to_string(kMaxStoragePath) + " characters");
    return p;
}

// QEMU's option syntax: a comma inside a value is written twice.
std::string qemu_option_value(const std::string& s) {
    std::string out;
    for (const char c : s) {
        out += c;
        if (c == ',') out += ',';
    }
    return out;
}

struct BoardSpec {
    const char* machine;
    const char* cpu;
};

BoardSpec board_spec(const std::string& board) {
    if (board == "qemu-m7") return {"mps2-an500", "cortex-m7"};
    if (board == "qemu-m3") return {"mps2-an385", "cortex-m3"};
    throw std::invalid_argument("--board: qemu-m7 or qemu-m3");
}

fs::path firmware_image(const EmulateArgs& a) {
    if (!a.image.empty()) {
        if (!fs::exists(a.image)) throw std::invalid_argument("--image: no such file " + a.image);
        return a.image;
    }
    const char* env = std::getenv("PIEZOLOOP_FIRMWARE_DIR");
    const fs::path root = env != nullptr && *env != '\0' ? fs::path(env) : fs::path(PIEZOLOOP_DEFAULT_FIRMWARE_DIR);
    const fs::path p = root / ("fw-" + a.board) / "firmware" / "servo.elf";
    if (!fs::exists(p))
        throw std::invalid_argument("no firmware image at " + p.string() + ": build it with `cmake --preset fw-" + a.board +
                                    " && cmake --build --preset fw-" + a.board +
                                    "` in the source tree, or give --image PATH or PIEZOLOOP_FIRMWARE_DIR=<dir with fw-" +
                                    a.board + "/firmware/>");
    return p;
}

// One axis's stage (a single-axis scenario, or plant.axes[i] alone), loop
// rate and full scales as the board's profile.
EmulationProfile axis_profile(const sim::Scenario& s, const sim::CaseSpec* c) {
    sim::LoopModel m;
    sim::build_stage(s, c, 10, m);
    EmulationProfile p;
    const double r = std::round(s.rate_Hz);
    if (std::fabs(r - s.rate_Hz) > 0.0 || r < 1.0)
        throw std::invalid_argument(s.name + ": loop.rate_Hz " + std::to_string(s.rate_Hz) + " is not a whole number of Hz");
    p.loop_rate_Hz = static_cast<uint32_t>(r);
    p.position_full_scale_um = s.setup.position.full_scale;
    p.voltage_full_scale_V = s.setup.voltage.full_scale;
    p.stage = m.stage;
    p.stage.rate_Hz = static_cast<float>(p.loop_rate_Hz);
    if (const Status st = validate(p); !st.ok())
        throw std::invalid_argument(s.name + ": the emulated board cannot run this stage: " + piezoloop::describe(st));
    return p;
}

// The boards' axis counts (their self-tests' kSelfTestAxes).
int board_axes(const std::string& board) { return board == "qemu-m7" ? 3 : 2; }

// The scenario's stage as the board's profile and, for a stage of coupled
// axes, the axes blob beside it (axes.axes == 0: one axis).
EmulationProfile scenario_profile(const EmulateArgs& a, json& info, EmulationAxesProfile& axes) {
    const sim::Scenario s = sim::load_scenario(a.scenario);
    const sim::CaseSpec* c = a.case_name.empty() ? nullptr : &s.find_case(a.case_name);
    axes.axes = 0;
    info["scenario"] = s.name;
    if (c != nullptr) info["case"] = c->name;
    if (!s.multi_axis()) {
        const EmulationProfile p = axis_profile(s, c);
        info["loop_rate_Hz"] = p.loop_rate_Hz;
        return p;
    }
    const int n = static_cast<int>(s.axes.size());
    if (n > board_axes(a.board))
        throw std::invalid_argument("--scenario: " + s.name + " has " + std::to_string(n) + " axes, " + a.board +
                                    " runs at most " + std::to_string(board_axes(a.board)) +
                                    (a.board == "qemu-m7" ? "" : " (3 axes: --board qemu-m7)"));
    std::vector<EmulationProfile> per_axis;
    for (int i = 0; i < n; ++i) {
        const sim::Scenario alone = sim::axis_alone(s, static_cast<std::size_t>(i));
        const sim::CaseSpec* ac = c == nullptr || c->axis_cases.empty() ? c : &c->axis_cases[static_cast<std::size_t>(i)];
        per_axis.push_back(axis_profile(alone, ac));
    }
    axes.axes = n;
    axes.stage = sim::coupled_stage_config(s);
    for (int i = 0; i < n; ++i) {
        const std::size_t k = static_cast<std::size_t>(i);
        axes.position_full_scale_um[k] = per_axis[k].position_full_scale_um;
        axes.voltage_full_scale_V[k] = per_axis[k].voltage_full_scale_V;
        axes.stage.axis[k] = per_axis[k].stage;  // as a case builds it (its hysteresis override included)
    }
    CoupledStage scratch;
    if (const Status st = validate(axes, per_axis[0], scratch); !st.ok())
        throw std::invalid_argument(s.name + ": the emulated board cannot run this stage: " + piezoloop::describe(st));
    info["loop_rate_Hz"] = per_axis[0].loop_rate_Hz;
    info["axes"] = n;
    return per_axis[0];
}

// A blob into the temporary folder, loaded at `address` by QEMU's generic loader.
void load_blob(std::vector<std::string>& args, const fs::path& file, std::span<const uint8_t> blob, uint32_t address) {
    std::ofstream f(file, std::ios::binary);
    f.write(reinterpret_cast<const char*>(blob.data()), static_cast<std::streamsize>(blob.size()));
    f.close();
    if (!f) throw std::runtime_error("cannot write " + file.string());
    char addr[32];
    std::snprintf(addr, sizeof addr, "0x%x", address);
    args.emplace_back("-device");
    args.push_back("loader,file=" + file.string() + ",addr=" + addr);
}

int free_port() {
    const int fd = ::socket(AF_INET, SOCK_STREAM, 0);
    sockaddr_in a{};
    a.sin_family = AF_INET;
    a.sin_addr.s_addr = htonl(INADDR_LOOPBACK);
    socklen_t len = sizeof a;
    if (::bind(fd, reinterpret_cast<sockaddr*>(&a), sizeof a) != 0 ||
        ::getsockname(fd, reinterpret_cast<sockaddr*>(&a), &len) != 0) {
        ::close(fd);
        throw std::runtime_error("cannot find a free TCP port");
    }
    ::close(fd);
    return ntohs(a.sin_port);
}

int run_emulate(const EmulateArgs& a) {
    const BoardSpec spec = board_spec(a.board);
    // The storage before the image: a bad --storage is the user's to fix
    // whatever the build tree holds.
    const fs::path storage = a.storage.empty() ? fs::path() : storage_file(a.storage);
    // The scenario's stage next: what the board cannot run is refused
    // whatever the build tree holds.
    json info = {{"board", a.board}};
    EmulationAxesProfile axes;
    const std::optional<EmulationProfile> profile =
        a.scenario.empty() ? std::nullopt : std::optional(scenario_profile(a, info, axes));
    const fs::path image = firmware_image(a);
    fs::path tmpdir;
    std::vector<std::string> args;
    const char* qemu_env = std::getenv("QEMU_SYSTEM_ARM");
    args.push_back(qemu_env != nullptr && *qemu_env != '\0' ? qemu_env : "qemu-system-arm");
    const int port = a.port > 0 ? a.port : free_port();
    // The link's command line (docs/boards.md): icount keeps virtual time
    // exact; wait=off lets the board boot before the first client, and the
    // server takes a new client after one disconnects.
    for (const char* s : {"-M", spec.machine, "-cpu", spec.cpu, "-nographic", "-monitor", "none", "-icount",
                          "shift=0,sleep=off"})
        args.emplace_back(s);
    if (a.storage.empty()) {
        args.emplace_back("-semihosting");
    } else {
        // The firmware finds its storage file as the last semihosting
        // argument, --storage=PATH (SYS_GET_CMDLINE).
        const fs::path& file = storage;
        args.emplace_back("-semihosting-config");
        args.push_back("enable=on,arg=servo,arg=--storage=" + qemu_option_value(file.string()));
        info["storage"] = file.string();
    }
    args.emplace_back("-kernel");
    args.push_back(image.string());
    args.emplace_back("-serial");
    args.push_back("tcp:127.0.0.1:" + std::to_string(port) + ",server=on,wait=off");
    if (profile) {
        const EmulationProfile& p = *profile;
        tmpdir = fs::temp_directory_path() / ("piezoloop-emulate-" + std::to_string(::getpid()));
        fs::create_directories(tmpdir);
        std::array<uint8_t, kEmulationProfileMaxBytes> blob{};
        const std::size_t n = encode_profile(p, blob);
        if (n == 0) throw std::runtime_error("emulation profile does not fit");
        load_blob(args, tmpdir / "profile.bin", std::span(blob).first(n), kEmulationProfileAddress);
        if (axes.axes != 0) {
            std::array<uint8_t, kEmulationAxesProfileMaxBytes> axes_blob{};
            const std::size_t m = encode_axes_profile(axes, axes_blob);
            if (m == 0) throw std::runtime_error("emulation axes profile does not fit");
            load_blob(args, tmpdir / "axes.bin", std::span(axes_blob).first(m), kEmulationAxesProfileAddress);
        }
    }
    struct TmpCleanup {
        fs::path dir;
        ~TmpCleanup() {
            std::error_code ec;
            if (!dir.empty()) fs::remove_all(dir, ec);
        }
    } cleanup{tmpdir};

    const StopSignals stop_signals;
    // QEMU's own output (the semihosting console: a CPU fault, a bad
    // profile) goes to our stderr; stdout carries only the JSON line.
    posix_spawn_file_actions_t fa;
    posix_spawn_file_actions_init(&fa);
    posix_spawn_file_actions_adddup2(&fa, STDERR_FILENO, STDOUT_FILENO);
    posix_spawn_file_actions_addopen(&fa, STDIN_FILENO, "/dev/null", O_RDONLY, 0);
    std::vector<char*> argv;
    for (std::string& s : args) argv.push_back(s.data());
    argv.push_back(nullptr);
    pid_t pid = 0;
    const int rc = posix_spawnp(&pid, argv[0], &fa, nullptr, argv.data(), environ);
    posix_spawn_file_actions_destroy(&fa);
    if (rc != 0) throw hostlink::LinkError(std::string("cannot start ") + argv[0] + ": " + std::strerror(rc));

    auto stop_qemu = [&] {
        ::kill(pid, SIGTERM);
        for (int i = 0; i < 50; ++i) {
            if (::waitpid(pid, nullptr, WNOHANG) == pid) return;
            std::this_thread::sleep_for(std::chrono::milliseconds(20));
        }
        ::kill(pid, SIGKILL);
        ::waitpid(pid, nullptr, 0);
    };
    auto exited = [&](int& status) { return ::waitpid(pid, &status, WNOHANG) == pid; };

    // Ready once the board answers Hello on its port.
    const std::string address = "tcp:127.0.0.1:" + std::to_string(port);
    const auto deadline = std::chrono::steady_clock::now() + std::chrono::duration<double>(a.boot_timeout_s);
    std::string last_error;
    int status = 0;
    bool ready = false;
    while (!ready) {
        if (StopSignals::requested()) {
            stop_qemu();  // interrupted while booting: what the user asked for
            return kExitOk;
        }
        if (exited(status)) throw hostlink::LinkError("QEMU exited before the board answered (status " + std::to_string(status) + ")");
        if (std::chrono::steady_clock::now() > deadline) {
            stop_qemu();
            throw hostlink::LinkError("the emulated board did not answer on " + address + ": " + last_error);
        }
        try {
            hostlink::Client::Options o;
            o.timeout = std::chrono::milliseconds(2000);
            hostlink::Client c(hostlink::open_tcp("127.0.0.1", static_cast<uint16_t>(port), std::chrono::milliseconds(200)), o);
            const link::HelloReply& h = c.hello();
            info["firmware"] = {{"board", h.board.data()}, {"version", h.firmware_version.data()}, {"serial", h.serial.data()},
                                {"loop_rate_Hz", h.loop_rate_Hz}};
            const link::StatusReply st = c.status();
            if (st.tick.board_faults != 0)
                std::cerr << "warning: the board reports fault bits " << st.tick.board_faults
                          << " (bit 0: the emulation profile was rejected; see QEMU's output above)\n";
            if (!a.storage.empty()) {
                info["storage_at_boot"] = link::storage_state_name(st.storage);
                const bool ignored = st.storage != link::StorageState::kApplied && st.storage != link::StorageState::kEmpty;
                if (ignored)
                    std::cerr << "warning: " << storage_state_text(st.storage)
                              << (st.storage_field[0] != '\0' ? std::string(" (") + st.storage_group.data() + "." +
                                                                    st.storage_field.data() + ": " +
                                                                    st.storage_message.data() + ")"
                                                              : std::string())
                              << "\n";
            }
            ready = true;
        } catch (const std::exception& e) {
            last_error = e.what();
            std::this_thread::sleep_for(std::chrono::milliseconds(100));
        }
    }
    json line = {{"device", address}, {"board", a.board}, {"pid", pid}, {"image", image.string()}};
    for (auto it = info.begin(); it != info.end(); ++it)
        if (!line.contains(it.key())) line[it.key()] = it.value();
    std::cout << line.dump() << std::endl;

    while (!StopSignals::requested()) {
        if (exited(status)) {
            std::cerr << "QEMU exited (status " << status << ")\n";
            return WIFEXITED(status) && WEXITSTATUS(status) == 0 ? kExitOk : kExitLinkOrDevice;
        }
        std::this_thread::sleep_for(std::chrono::milliseconds(100));
    }
    stop_qemu();
    return 0;
}

void add_emulate(CLI::App& app) {
    auto a = std::make_shared<EmulateArgs>();
    CLI::App* cmd = app.add_subcommand(
        "emulate", "Run an emulated board (QEMU) with a scenario's stage; prints its --device address as JSON, "
                   "then runs until interrupted");
    cmd->add_option("--board", a->board, "qemu-m7 (float core) or qemu-m3 (Q31 core)")
        ->check(CLI::IsMember({"qemu-m7", "qemu-m3"}));
    cmd->add_option("--scenario", a->scenario, "scenario file: its stage, loop rate and full scales (default: the "
                                               "reference stage at 100 kHz)")
        ->check(CLI::ExistingFile);
    cmd->add_option("--case", a->case_name, "case whose plant hysteresis override the stage takes");
    cmd->add_option("--port", a->port, "TCP port of the link (default: a free one)")->check(CLI::Range(1, 65535));
    cmd->add_option("--image", a->image, "servo.elf to run (default: $PIEZOLOOP_FIRMWARE_DIR or the build tree, "
                                         "fw-<board>/firmware/servo.elf)");
    cmd->add_option("--storage", a->storage,
                    "host file the board keeps its parameter set in between runs (`save`, `load`, `forget`; "
                    "applied at boot after validation): a regular file, created empty if missing; a device, "
                    "FIFO, directory or read-only file is refused. Without it the board has no storage");
    cmd->add_option("--boot-timeout-s", a->boot_timeout_s, "give up if the board does not answer")
        ->check(CLI::Range(0.5, 600.0));
    cmd->callback([a] {
        guarded([&] {
            if (!a->case_name.empty() && a->scenario.empty()) throw std::invalid_argument("--case needs --scenario");
            return run_emulate(*a);
        });
    });
}

void add_devices(CLI::App& app) {
    CLI::App* cmd = app.add_subcommand("devices", "List attached USB boards and how to start an emulated one");
    cmd->callback([] {
        guarded([] {
            json out;
            out["usb"] = json::array();
            try {
                out["usb"] = usb_boards_json();
            } catch (const std::exception& e) {
                out["usb_error"] = e.what();
            }
            out["emulated"] =
                "start one with `piezoloop emulate --board qemu-m7|qemu-m3 [--scenario configs/S.json]`: it prints "
                "{\"device\": \"tcp:127.0.0.1:PORT\", ...}; then `piezoloop --device tcp:127.0.0.1:PORT status`";
            out["serial"] = "a UART bridge: --device serial:/dev/ttyACM0@115200";
            std::cout << out.dump(1) << "\n";
        });
    });
}

void add_emulate_commands(CLI::App& app) {
    add_emulate(app);
    add_devices(app);
}

const bool registered_emulate_commands = register_command(61, add_emulate_commands);

}  // namespace
}  // namespace piezoloop::cli
