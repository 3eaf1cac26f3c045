// One controlling page at a time: every open page (one live stream each) is a
// viewer with its own id; one of them may hold the control seat and then
// alone sends what changes the board (arm, disarm, parameters, waves);
// the others watch. The seat frees itself when its holder's stream closes
// (the tab is closed or the network drops), or when its holder releases it.
#pragma once

#include <mutex>
#include <optional>
#include <set>
#include <string>

namespace piezoloop::ui {

class ControlSeat {
public:
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

private:
    mutable std::mutex m_;
    std::set<std::string> viewers_;
    std::optional<std::string> holder_;
};

}  // namespace piezoloop::ui
