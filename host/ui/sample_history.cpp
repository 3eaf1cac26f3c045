#include "ui/sample_history.hpp"

#include <algorithm>
#include <cmath>

namespace piezoloop::ui {

SampleHistory::SampleHistory(std::vector<Signal> signals, double rate_Hz, std::size_t capacity)
    : signals_(std::move(signals)), rate_Hz_(rate_Hz), capacity_(std::max<std::size_t>(capacity, 2)),
      values_(signals_.size()) {}

std::vector<Signal> SampleHistory::signals() const {
    const std::lock_guard lock(m_);
    return signals_;
}

uint64_t SampleHistory::generation() const {
    const std::lock_guard lock(m_);
    return generation_;
}

std::optional<std::size_t> SampleHistory::find(const std::string& name) const {
    const std::lock_guard lock(m_);
    for (std::size_t i = 0; i < signals_.size(); ++i)
        if (signals_[i].name == name) return i;
    return std::nullopt;
}

void SampleHistory::reset(std::vector<Signal> signals) {
    const std::lock_guard lock(m_);
    signals_ = std::move(signals);
    values_.assign(signals_.size(), {});
    ticks_.clear();
    arrival_ms_.clear();
    ++generation_;
}

void SampleHistory::append(uint64_t tick, std::span<const float> values, int64_t arrival_ms) {
    const std::lock_guard lock(m_);
    ticks_.push_back(tick);
    for (std::size_t s = 0; s < values_.size(); ++s) values_[s].push_back(s < values.size() ? values[s] : 0.0f);
    arrival_ms_.push_back(arrival_ms);
    if (ticks_.size() > capacity_) {
        ticks_.pop_front();
        for (auto& v : values_) v.pop_front();
        arrival_ms_.pop_front();
    }
}

void SampleHistory::clear() {
    const std::lock_guard lock(m_);
    ticks_.clear();
    for (auto& v : values_) v.clear();
    arrival_ms_.clear();
}

std::size_t SampleHistory::size() const {
    const std::lock_guard lock(m_);
    return ticks_.size();
}

std::optional<double> SampleHistory::end_s() const {
    const std::lock_guard lock(m_);
    if (ticks_.empty()) return std::nullopt;
    return static_cast<double>(ticks_.back() + 1) / rate_Hz_;
}

std::size_t SampleHistory::lower_index(double t_s) const {
    std::size_t lo = 0, hi = ticks_.size();
    while (lo < hi) {
        const std::size_t mid = (lo + hi) / 2;
        if (time_of(mid) < t_s) lo = mid + 1;
        else hi = mid;
    }
    return lo;
}

SampleWindow SampleHistory::window(double t0_s, double span_s) const {
    const std::lock_guard lock(m_);
    SampleWindow w;
    w.signals = signals_;
    w.values.resize(values_.size());
    const std::size_t a = lower_index(t0_s), b = lower_index(t0_s + span_s);
    if (b <= a) return w;
    w.t_s.reserve(b - a);
    for (std::size_t i = a; i < b; ++i) w.t_s.push_back(time_of(i));
    for (std::size_t s = 0; s < values_.size(); ++s)
        w.values[s].assign(values_[s].begin() + static_cast<std::ptrdiff_t>(a),
                           values_[s].begin() + static_cast<std::ptrdiff_t>(b));
    w.newest_arrival_ms = arrival_ms_[b - 1];
    return w;
}

std::optional<double> SampleHistory::last_crossing(const Trigger& trig, double latest_s, double look_back_s) const {
    const std::lock_guard lock(m_);
    if (trig.signal >= values_.size() || ticks_.size() < 2) return std::nullopt;
    const std::deque<float>& v = values_[trig.signal];
    const std::size_t first = std::max<std::size_t>(lower_index(latest_s - look_back_s), 1);
    std::size_t i = std::min(lower_index(latest_s + 0.5 / rate_Hz_), ticks_.size() - 1);
    for (; i >= first; --i) {
        const double before = v[i - 1], now = v[i];
        const bool crossed = trig.rising ? (before < trig.level && now >= trig.level)
                                         : (before > trig.level && now <= trig.level);
        if (crossed && time_of(i) <= latest_s) return time_of(i);
    }
    return std::nullopt;
}

}  // namespace piezoloop::ui
