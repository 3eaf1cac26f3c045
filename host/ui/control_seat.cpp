#include "ui/control_seat.hpp"

#include "ui/access.hpp"

namespace piezoloop::ui {

std::string ControlSeat::join() {
    std::string id = random_hex(8);
    const std::lock_guard lock(m_);
    viewers_.insert(id);
    return id;
}

void ControlSeat::leave(const std::string& viewer) {
    const std::lock_guard lock(m_);
    viewers_.erase(viewer);
    if (holder_ == viewer) holder_.reset();
}

bool ControlSeat::claim(const std::string& viewer) {
    const std::lock_guard lock(m_);
    if (viewers_.count(viewer) == 0) return false;
    if (holder_ && *holder_ != viewer) return false;
    holder_ = viewer;
    return true;
}

void ControlSeat::release(const std::string& viewer) {
    const std::lock_guard lock(m_);
    if (holder_ == viewer) holder_.reset();
}

bool ControlSeat::holds(const std::string& viewer) const {
    const std::lock_guard lock(m_);
    return holder_ && *holder_ == viewer;
}

std::optional<std::string> ControlSeat::holder() const {
    const std::lock_guard lock(m_);
    return holder_;
}

std::size_t ControlSeat::viewers() const {
    const std::lock_guard lock(m_);
    return viewers_.size();
}

}  // namespace piezoloop::ui
