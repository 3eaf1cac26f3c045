// The console's one link to the board: a thread that takes the recorder's
// log blocks as they arrive (into the SampleHistory the pages' scopes
// read) and polls the board's status, and the requests the pages make
// (arm, disarm, parameters, waves) between its reads. The board's recorder
// runs continuously, r, y, e, u (as many as the board records), for as long
// as the console runs; its recorder group is the console's, not a form's.
#pragma once

#include <atomic>
#include <functional>
#include <memory>
#include <mutex>
#include <string>
#include <thread>

#include <nlohmann/json.hpp>

#include "link/client.hpp"
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
    nlohmann::json groups_json();  // every group a form edits
    nlohmann::json group_json(const std::string& group);
    SetOutcome set_group(const std::string& group, const nlohmann::json& fields);
    // {trajectory, frequency_Hz, amplitude_um, offset, cycles, arm}: set the
    // trajectory group and start it (detached from this link's silence).
    nlohmann::json start_wave(const nlohmann::json& request);

    // Groups the parameter forms offer (not the recorder: the scope's).
    static const std::vector<std::string>& form_groups();

private:
    void run();
    void take_log_frames();
    void poll_status();
    template <class F>
    auto locked(F f) {
        const std::lock_guard lock(link_);
        return f(client_);
    }

    hostlink::Client client_;
    std::string address_;
    link::HelloReply hello_{};
    std::unique_ptr<SampleHistory> history_;
    std::mutex link_;
    std::thread thread_;
    std::atomic<bool> running_{false};
    mutable std::mutex status_m_;
    nlohmann::json status_;
    nlohmann::json limits_;
    std::string link_error_;
    std::atomic<uint64_t> status_serial_{0};
};

}  // namespace piezoloop::ui
