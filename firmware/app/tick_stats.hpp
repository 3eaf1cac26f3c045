// Per-tick execution time and the tick's timeliness, kept by the control
// interrupt itself (bounded time, no allocation).
//
// WorkStats: min / mean / max of a per-tick measurement (instructions on the
// QEMU boards, cycles on hardware).
//
// TickMonitor: overruns are never silent. From the timestamp at each tick's
// entry and at its DAC write, with the period P in timestamp counts:
//   late   ticks whose output reached the DAC more than P after the tick
//          started (the command came too late for its period; on the
//          emulated boards the plant model, which runs after the DAC
//          write, does not count here -- it is physics, not the
//          controller -- but if it delays the next tick by half a period
//          or more, that shows as missed);
//   missed periods in which no tick started: an entry-to-entry spacing d
//          means round(d / P) - 1 periods were skipped (a timer request
//          that arrives while the previous one is still pending is lost in
//          the hardware, so it can only be seen this way).
// overruns() = late + missed: the number of periods the loop did not serve
// on time.
#pragma once

#include <cstdint>

namespace piezoloop::fw {

struct WorkStats {
    uint32_t count = 0;
    uint32_t min = 0;
    uint32_t max = 0;
    uint64_t sum = 0;

    void add(uint32_t n) {
        if (count == 0 || n < min) min = n;
        if (n > max) max = n;
        sum += n;
        ++count;
    }
    // Mean in tenths, rounded (integer only: callable anywhere).
    uint64_t mean_tenths() const { return count == 0 ? 0 : (sum * 10u + count / 2u) / count; }
};

class TickMonitor {
public:
    // period: one tick period in timestamp counts; mask: the timestamp
    // counter's wrap mask (2^bits - 1).
    void reset(uint32_t period, uint32_t mask) {
        period_ = period;
        mask_ = mask;
        have_prev_ = false;
        late_ = missed_ = 0;
    }
    void on_entry(uint32_t now) {
        if (have_prev_) {
            const uint32_t d = (now - prev_entry_) & mask_;
            const uint32_t periods = (d + period_ / 2u) / period_;
            if (periods > 1u) missed_ += periods - 1u;
        }
        prev_entry_ = now;
        have_prev_ = true;
    }
    void on_output(uint32_t now) {
        if (((now - prev_entry_) & mask_) > period_) ++late_;
    }

    uint32_t late() const { return late_; }
    uint32_t missed() const { return missed_; }
    uint32_t overruns() const { return late_ + missed_; }

private:
    uint32_t period_ = 1;
    uint32_t mask_ = 0xFFFFFFFFu;
    uint32_t prev_entry_ = 0;
    bool have_prev_ = false;
    uint32_t late_ = 0;
    uint32_t missed_ = 0;
};

}  // namespace piezoloop::fw
