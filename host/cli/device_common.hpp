// Shared by the device subcommands (cmd_device.cpp, cmd_emulate.cpp): the
// global --device address, opening a client, and a scenario case turned
// into the link's parameter groups.
#pragma once

#include <functional>
#include <string>
#include <vector>

#include <nlohmann/json.hpp>

#include "exit_codes.hpp"
#include "link/client.hpp"
#include "sim/build_case.hpp"
#include "sim/experiments.hpp"
#include "sim/scenario.hpp"

namespace piezoloop::cli {

// Set by main() from --device / $PIEZOLOOP_DEVICE.
std::string& device_address();

// Opens the --device transport and says hello (throws std::invalid_argument
// without --device, hostlink::LinkError when the board cannot be reached).
hostlink::Client open_device(int timeout_ms = 3000);

// --axis x|y|z|all on a board of `count` axes: the axis index, or kAllAxes
// for "all" (only where `all_allowed`). Empty: the only axis of a
// single-axis board; on a multi-axis board std::invalid_argument naming the
// choices (exit 2), as for a name the board has not got.
inline constexpr int kAllAxes = -1;
int resolve_axis(const std::string& axis, unsigned count, bool all_allowed);
// "x", "y", "z" for axis 0, 1, 2.
const char* axis_name(int axis);

// `measure`: true for a board (--device given, no --scenario), false for the
// simulator (--scenario, no --device); std::invalid_argument naming the
// option otherwise, and for --case (simulator only) or --restart-stage
// (board only) given to the other.
bool measure_on_board(const std::string& scenario, const std::string& case_name, bool restart_stage);

// `measure --scenario S [--case C] [--sample float|q31]`: the case to run
// (null: the scenario's stage alone, float), with the core's sample type
// overridden when `sample` is given; `storage` holds the copy that needs.
const sim::CaseSpec* measured_case(const sim::Scenario& s, const std::string& case_name, const std::string& sample,
                                   sim::CaseSpec& storage);

// `piezoloop devices`: the attached USB boards, each with the --device
// address that opens it (throws hostlink::LinkError when USB cannot be
// enumerated).
nlohmann::json usb_boards_json();

// A case's controller as the link groups, in the order they are sent.
struct CaseGroups {
    link::LimitsParams limits;
    link::FeedforwardParams feedforward;
    link::FeedbackParams feedback;
    link::RepetitiveParams rc;
};
CaseGroups case_groups(const PipelineParams& p);

// The limits intersected with the board's hard limits; each clipped field is
// described in `clipped` ("limits.u_max_V: 12 -> 10 (board hard limit)").
link::LimitsParams clip_to_hard_limits(const link::LimitsParams& l, const link::HelloReply& h,
                                       std::vector<std::string>& clipped);

// `piezoloop set --scenario S --case C`: the case built for the board's
// sample type and loop rate, its limits clipped to the board's hard limits,
// the groups sent in an order the board accepts (disarmed only). Lines for
// the user ("note: ...", "clipped: ...") go to `note`; returns the summary
// JSON the command prints. Also used by the Python module's Device.
nlohmann::json send_scenario_case(hostlink::Client& c, const std::string& scenario, const std::string& case_name,
                                  double frequency_Hz, const std::function<void(const std::string&)>& note);

// The reference exactly as `piezoloop sim` plans it (sim::plan_run): range
// peak-to-peak, offset convention unipolar (from 0 up) or bipolar.
struct WaveRequest {
    std::string trajectory = "triangle";
    double frequency_Hz = 10.0;
    double amplitude_um = 0.0;   // peak-to-peak range
    std::string offset;          // unipolar | bipolar; empty: the scenario's, else unipolar
    std::string scenario;        // optional: its offset convention
    uint32_t cycles = 0;
};
// The request's trajectory, frequency (1e-4 to 5e5 Hz), amplitude (1e-6 to
// 1e3 um) and offset, named as the command line's options (the Python
// module's wave and record call it through wave_params too).
void check_wave_request(const WaveRequest& w);
// The trajectory group of a checked request.
link::TrajectoryParams wave_params(const WaveRequest& w, double rate_Hz);

// While one exists, SIGINT (Ctrl-C) and SIGTERM only set requested(): a
// session polls it, stops what runs on the board and keeps what arrived.
class StopSignals {
public:
    StopSignals();
    ~StopSignals();
    StopSignals(const StopSignals&) = delete;
    StopSignals& operator=(const StopSignals&) = delete;
    static bool requested();

private:
    void (*int_)(int);
    void (*term_)(int);
};

// Runs a board session f() under StopSignals: when Ctrl-C (or SIGTERM) ended
// it early, whatever the session threw once the board was left clean
// becomes LostData (exit 4: an interrupted run whose data is incomplete,
// as `record`), naming what was interrupted.
template <class F>
auto interruptible(const char* what, F&& f) -> decltype(f()) {
    try {
        return f();
    } catch (const std::exception& e) {
        if (!StopSignals::requested()) throw;
        throw LostData(std::string(what) + " interrupted (Ctrl-C or SIGTERM) before the end, nothing written: " +
                       e.what());
    }
}

// A progress bar on stderr when it is a terminal.
class ProgressBar {
public:
    explicit ProgressBar(std::string label);
    void update(double fraction);
    void done();

private:
    std::string label_;
    bool tty_;
    int last_ = -1;
};

}  // namespace piezoloop::cli
