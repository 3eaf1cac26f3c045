// One controlling page at a time: every open page (one live stream each) is a
// viewer with its own id; one of them may hold the control seat and then
// alone sends what changes the board (arm, disarm, parameters, waves);
// the others watch. The seat frees itself when its holder's stream closes
// (the tab is closed or the network drops), or when its holder releases it.
//
// A watcher may ask for the seat while another page holds it: the holder's
// page is asked and gives it or keeps it; without an answer within the
// answer timeout (kAnswerTimeout unless given) the seat passes to the asker (an unattended page does not
// keep everyone else from stopping the stage). One request at a time; a
// holder that leaves meanwhile leaves the seat to the asker.
#pragma once

#include <atomic>
#include <chrono>
#include <cstdint>
#include <mutex>
#include <optional>
#include <set>
#include <string>

namespace piezoloop::ui {

class ControlSeat {
public:
    using Clock = std::chrono::steady_clock;
    static constexpr std::chrono::seconds kAnswerTimeout{10};

    explicit ControlSeat(std::chrono::seconds answer_timeout = kAnswerTimeout) : answer_timeout_(answer_timeout) {}

    struct Request {
        std::string from;
        Clock::time_point deadline;
    };
    enum class Asked {
        kTaken,    // the seat was free (or the asker's): taken at once
        kAsked,    // the holder is asked
        kRefused,  // an unknown viewer, or another page's request is pending
    };

    // A new viewer (its stream opened); returns its id.
    std::string join();
    // Its stream closed: it leaves, and the seat if it held it.
    void leave(const std::string& viewer);
    // Takes the seat if it is free or already this viewer's; false when
    // another viewer holds it or the viewer is unknown.
    bool claim(const std::string& viewer);
    void release(const std::string& viewer);
    bool holds(const std::string& viewer) const;
    std::optional<std::string> holder() const;
    std::size_t viewers() const;

    // A watcher asks for the seat at `now`.
    Asked ask(const std::string& viewer, Clock::time_point now);
    // The holder's answer to the pending request; false when `holder` does
    // not hold the seat or nothing is pending.
    bool answer(const std::string& holder, bool give);
    // A request unanswered past its deadline passes the seat; true if so.
    bool expire(Clock::time_point now);
    std::optional<Request> request() const;
    // The viewer whose last request the holder refused (until it asks again).
    bool was_refused(const std::string& viewer) const;
    // Changes whenever the holder or the request does.
    uint64_t serial() const { return serial_.load(); }

private:
    void changed() { ++serial_; }  // m_ held

    const std::chrono::seconds answer_timeout_;
    mutable std::mutex m_;
    std::set<std::string> viewers_;
    std::optional<std::string> holder_;
    std::optional<Request> request_;
    std::set<std::string> refused_;
    std::atomic<uint64_t> serial_{0};
};

}  // namespace piezoloop::ui
