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
    refused_.erase(viewer);
    if (request_ && request_->from == viewer) request_.reset();
    if (holder_ == viewer) {
        holder_.reset();
        if (request_) holder_ = request_->from;  // the asker was waiting for it
        request_.reset();
    }
    changed();
}

bool ControlSeat::claim(const std::string& viewer) {
    const std::lock_guard lock(m_);
    if (viewers_.count(viewer) == 0) return false;
    if (holder_ && *holder_ != viewer) return false;
    if (holder_ != viewer) changed();
    holder_ = viewer;
    return true;
}

void ControlSeat::release(const std::string& viewer) {
    const std::lock_guard lock(m_);
    if (holder_ != viewer) return;
    holder_.reset();
    if (request_) holder_ = request_->from;
    request_.reset();
    changed();
}

ControlSeat::Asked ControlSeat::ask(const std::string& viewer, Clock::time_point now) {
    const std::lock_guard lock(m_);
    if (viewers_.count(viewer) == 0) return Asked::kRefused;
    refused_.erase(viewer);
    if (!holder_ || *holder_ == viewer) {
        holder_ = viewer;
        changed();
        return Asked::kTaken;
    }
    if (request_ && request_->from != viewer) return Asked::kRefused;
    if (!request_) {
        request_ = Request{viewer, now + answer_timeout_};
        changed();
    }
    return Asked::kAsked;
}

bool ControlSeat::answer(const std::string& holder, bool give) {
    const std::lock_guard lock(m_);
    if (!holder_ || *holder_ != holder || !request_) return false;
    if (give) holder_ = request_->from;
    else refused_.insert(request_->from);
    request_.reset();
    changed();
    return true;
}

bool ControlSeat::expire(Clock::time_point now) {
    const std::lock_guard lock(m_);
    if (!request_ || now < request_->deadline) return false;
    holder_ = request_->from;
    request_.reset();
    changed();
    return true;
}

std::optional<ControlSeat::Request> ControlSeat::request() const {
    const std::lock_guard lock(m_);
    return request_;
}

bool ControlSeat::was_refused(const std::string& viewer) const {
    const std::lock_guard lock(m_);
    return refused_.count(viewer) > 0;
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
