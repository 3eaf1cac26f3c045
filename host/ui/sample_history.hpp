// The recorder's signals as they arrived from the board, the last
// `capacity` frames, in physical units (µm, V), keyed by signal name (a
// signal of another axis later is another name). Written by the link's
// thread, read by the pages' streams; every call takes the lock. The
// signals change when the scope's channels do (reset): the history starts
// again, and its generation counts the changes.
#pragma once

#include <cstdint>
#include <deque>
#include <mutex>
#include <optional>
#include <span>
#include <string>
#include <vector>

namespace piezoloop::ui {

struct Signal {
    std::string name;  // "r", "y", ...
    std::string unit;  // "um", "V"
};

// Samples copied out of the history: t_s ascending, one value column per
// signal, of the signals the history held then.
struct SampleWindow {
    std::vector<Signal> signals;
    std::vector<double> t_s;
    std::vector<std::vector<float>> values;  // [signal][sample]
    int64_t newest_arrival_ms = 0;           // host clock (ms since the epoch) when the last sample arrived
};

// A trigger: the signal crossing the level in the given direction.
struct Trigger {
    std::size_t signal = 0;  // index into signals()
    double level = 0.0;
    bool rising = true;
};

class SampleHistory {
public:
    SampleHistory(std::vector<Signal> signals, double rate_Hz, std::size_t capacity);

    std::vector<Signal> signals() const;
    uint64_t generation() const;
    double rate_Hz() const { return rate_Hz_; }
    std::optional<std::size_t> find(const std::string& name) const;
    // Other signals from now on: the samples so far are dropped.
    void reset(std::vector<Signal> signals);

    // One frame: its tick (loop ticks from the first frame) and one value per
    // signal; `arrival_ms` is when its block reached the host.
    void append(uint64_t tick, std::span<const float> values, int64_t arrival_ms);
    void clear();
    std::size_t size() const;
    // Time just after the newest sample (its time + one tick); nullopt while empty.
    std::optional<double> end_s() const;

    // The samples with t in [t0_s, t0_s + span_s).
    SampleWindow window(double t0_s, double span_s) const;

    // Time of the latest crossing of the trigger no later than `latest_s`
    // (the sample at or after the level), looking back at most `look_back_s`.
    std::optional<double> last_crossing(const Trigger& trig, double latest_s, double look_back_s) const;

private:
    double time_of(std::size_t i) const { return static_cast<double>(ticks_[i]) / rate_Hz_; }
    std::size_t lower_index(double t_s) const;  // first sample with t >= t_s

    std::vector<Signal> signals_;
    uint64_t generation_ = 0;
    double rate_Hz_;
    std::size_t capacity_;
    mutable std::mutex m_;
    std::deque<uint64_t> ticks_;
    std::vector<std::deque<float>> values_;
    std::deque<int64_t> arrival_ms_;
};

}  // namespace piezoloop::ui
