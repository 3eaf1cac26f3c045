// The console's one link to the board: a thread that takes the recorder's
// log blocks as they arrive (into the SampleHistory the pages' scopes
// read) and polls the board's status, and the requests the pages make
// (arm, disarm, parameters, waves) between its reads. The board's recorder
// runs continuously, r, y, e, u (as many as the board records; on a board
// of axes every axis's r and y, another axis's named "y.r", "y.y", "z.y",
// while there is room), for as long as the console runs; its recorder group
// is the console's, not a form's.
// A measurement (frequency response, step, loops) takes the link and the
// recorder over for its run: the history then gets the measurement's r, y
// and u (e is not recorded meanwhile: a gap), the status is polled between
// its reads, other requests are refused (BoardBusy), and the console's
// recording is re-armed after it.
#pragma once

#include <atomic>
#include <functional>
#include <memory>
#include <mutex>
#include <stdexcept>
#include <string>
#include <thread>

#include <nlohmann/json.hpp>

#include "commission_axes.hpp"
#include "commission_session.hpp"
#include "link/client.hpp"
#include "link/measure_session.hpp"
#include "link/scan_session.hpp"
#include "ui/sample_history.hpp"

namespace piezoloop::ui {

// A parameter change's outcome: the group as the board then holds it, and,
// when refused, who refused, the field named and the message.
struct SetOutcome {
    bool ok = true;
    std::string refused_by;  // "board", or "host" (the field check before sending)
    std::string group, field;
    int index = -1;
    std::string message;
    nlohmann::json values;  // the group read back from the board
    nlohmann::json to_json() const;
};

// A request refused because a measurement holds the link.
struct BoardBusy : std::runtime_error {
    using std::runtime_error::runtime_error;
};

class BoardSession {
public:
    // `client` has said hello. `history_s`: seconds of samples kept.
    BoardSession(hostlink::Client client, double history_s);
    ~BoardSession();
    BoardSession(const BoardSession&) = delete;
    BoardSession& operator=(const BoardSession&) = delete;

    // Configures and arms the recorder, starts the reading thread.
    void start();
    void stop();

    const SampleHistory& history() const { return *history_; }
    std::string address() const { return address_; }

    // The scope's channels, by name: axis x's signals by their own (r, y,
    // e, u, u_ff, u_fb, u_rc, d), another axis's after its name (y.u,
    // z.r). Every channel the board can record, and how many at once.
    std::vector<std::string> channel_choices() const;
    std::size_t channel_capacity() const { return hello_.recorder_channels; }
    // Records these from now on (1 .. channel_capacity, each once): the
    // history starts again with them. std::invalid_argument naming
    // `channels`; BoardBusy while a measurement holds the recorder.
    void set_scope_channels(const std::vector<std::string>& names);

    // The last status poll with the meaning of faults, trip and stored set,
    // the link's counters and the limits group.
    nlohmann::json status_json() const;
    uint64_t status_serial() const { return status_serial_.load(); }

    // Requests on the board, each under the link's lock; a failure throws
    // (hostlink::LinkError, DeviceError, std::invalid_argument).
    void arm();
    void disarm();
    void clear_trip();
    void stop_motion();  // the wave and any setpoint stream; the setpoint holds
    // A board of axes: an axis's groups by its name ("x", "y", "z"; "" on a
    // one-axis board); the board's groups (link) take none.
    int axis_count() const { return hello_.axis_count; }
    uint8_t axis_index(const std::string& name) const;  // std::invalid_argument naming `axis`
    nlohmann::json groups_json(uint8_t axis = 0);  // every group a form edits
    nlohmann::json group_json(const std::string& group, uint8_t axis = 0);
    SetOutcome set_group(const std::string& group, const nlohmann::json& fields, uint8_t axis = 0);
    // {trajectory, frequency_Hz, amplitude_um, offset, cycles, arm, axis}:
    // set the axis's trajectory group and start it (detached from this
    // link's silence).
    nlohmann::json start_wave(const nlohmann::json& request);

    // `measure frf`'s plan against the board (hostlink::plan_frf_device):
    // std::invalid_argument naming the option, before anything moves.
    measure::FrfPlan plan_frf(const measure::FrfRequest& r, uint8_t axis = 0);
    // `measure frf` on the board (hostlink::run_frf_device), the link held
    // for its whole run; o.progress is called with the link held.
    hostlink::DeviceFrfRun measure_frf(const measure::FrfRequest& r, hostlink::MeasureOptions o);
    bool measuring() const { return measuring_.load(); }

    // Steps and loops (hostlink::board_bounds, run_step_device,
    // run_loops_device), as measure_frf; the board's bounds and the setpoint
    // it holds (a closed-loop step starts there) for their requests.
    measure::MeasureBounds measure_bounds(uint8_t axis = 0);
    double setpoint_um(uint8_t axis = 0);
    measure::StepRun measure_step(const measure::StepRequest& r, hostlink::MeasureOptions o);
    measure::LoopsRun measure_loops(const measure::LoopsRequest& r, hostlink::MeasureOptions o);
    // A scan (hostlink::plan_board_scan, scan_on_board; the request's
    // fields named by `name` in its messages), as measure_step; its plan
    // alone first.
    void plan_scan(const scan::ScanRequest& r, const sim::Scenario* stage, const scan::FieldName& name);
    hostlink::BoardScan scan(const scan::ScanRequest& r, const sim::Scenario* stage, const scan::FieldName& name,
                             bool restart_stage, std::function<bool()> stop_requested,
                             const std::function<void(uint64_t tick, uint64_t total)>& progress);
    // `piezoloop commission` on the board (cli::run_commission_session), as
    // a measurement: its recordings into the history, s.recording_progress
    // called with the link held.
    nlohmann::json commission(cli::CommissionSession s, const std::function<void(const std::string&)>& note,
                              const std::function<bool()>& stop_requested);
    // `piezoloop commission --axes` on the board (cli::run_axes_commission_board),
    // as commission().
    nlohmann::json commission_axes(const cli::AxesCommission& a, bool save,
                                   const std::function<void(const std::string&)>& note,
                                   const std::function<bool()>& stop_requested);

    // Groups the parameter forms offer (not the recorder: the scope's).
    static const std::vector<std::string>& form_groups();

private:
    void run();
    void take_log_frames();
    // Frames [from, size) of the link's log into the history, placed after
    // the last one (the board's tick counter gives the gap between two
    // recordings); signals the log does not carry are NaN.
    void append_log_frames(std::size_t from);
    void poll_status();
    void poll_status_locked();  // the link's lock held
    void arm_console_recorder();  // the link's lock held
    // Runs `body` with the link held and the recorder taken over, its
    // recording(s) into the history as they arrive.
    void measure(hostlink::MeasureOptions o,
                 const std::function<void(hostlink::Client&, const hostlink::MeasureOptions&)>& body);
    template <class F>
    auto locked(F f) {
        if (measuring_) throw BoardBusy("a measurement is running: stop it first");
        const std::lock_guard lock(link_);
        return f(client_);
    }

    hostlink::Client client_;
    std::string address_;
    link::HelloReply hello_{};
    std::vector<uint8_t> channels_;   // the console recorder's channel ids, the history's signals in order
    link::StatusReply last_status_{};  // the last status poll (the link's lock held)
    std::unique_ptr<SampleHistory> history_;
    std::mutex link_;
    std::thread thread_;
    std::atomic<bool> running_{false};
    std::atomic<bool> measuring_{false};
    // The history's tick of log frame 0 of the current recording, and the
    // board's (wire) tick of the last frame appended.
    bool new_recording_ = true, have_last_ = false;
    uint64_t recording_offset_ = 0, last_tick_ = 0;
    uint32_t last_raw_ = 0;
    mutable std::mutex status_m_;
    nlohmann::json status_;
    nlohmann::json limits_;
    std::string link_error_;
    std::atomic<uint64_t> status_serial_{0};
};

// A form's "axis" field on `board` (empty on a one-axis board), refused at
// that field (FieldRefusal) when it names no axis of the board.
uint8_t axis_field(const BoardSession& board, const std::string& name);

}  // namespace piezoloop::ui
