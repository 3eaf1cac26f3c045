// The scan a device runs on a board of two or three axes (StartScan): a
// ScanFeed (scan/scan_feed.hpp) that sets the axes' setpoints and the board
// recorder's sync word in the tick's reading-independent half, and the
// figures the status reports.
//
// Contexts: start() and request_stop() from the main loop (start() only
// while the tick is masked or no scan runs: the tick reads the feed only
// while active), on_tick() from the tick, the figures from either (one
// aligned word each).
#pragma once

#include <atomic>
#include <cstdint>

#include "piezoloop/scan/scan_feed.hpp"
#include "piezoloop/status.hpp"

namespace piezoloop::link {

enum class ScanState : uint8_t { kNone = 0, kApproaching = 1, kScanning = 2, kEnded = 3 };

template <class T, class Multi>
class DeviceScan {
public:
    explicit DeviceScan(Multi& multi)
        : multi_(multi),
          feed_(multi.axis(0).setup().position, multi.axis(1).setup().position,
                multi.axis(Multi::axis_count() - 1).setup().position, multi.axis(0).setup().rate_Hz) {}

    // Validates the scan (the feed's refusals, group "scan") and plans its
    // approach from `from` (x, y, z); it runs from the next tick. Nothing
    // changes on error. The tick must be masked (or no scan active).
    Status start(ScanConfig c, T from_x, T from_y, T from_z) {
        c.sample_rate_Hz = multi_.axis(0).setup().rate_Hz;
        if (const Status s = feed_.start(c, from_x, from_y, from_z); !s.ok()) return s;
        stop_request_.store(false, std::memory_order_relaxed);
        approach_ticks_ = feed_.approach_ticks();
        ticks_ = 0;
        frames_ = 0;
        started_ = true;
        active_.store(true, std::memory_order_release);
        return ok_status();
    }

    void request_stop() { stop_request_.store(true, std::memory_order_release); }

    // Tick: while a scan runs, its setpoints and sync word; the tick after
    // its last, the sync word back to 0. Otherwise one branch.
    void on_tick() {
        if (!active_.load(std::memory_order_relaxed)) return;
        if (stop_request_.load(std::memory_order_acquire)) feed_.stop();
        if (!feed_.running()) {
            multi_.set_sync(0);
            active_.store(false, std::memory_order_release);
            return;
        }
        const ScanPoint<T> p = feed_.feed(multi_);
        multi_.set_sync(p.sync);
        ticks_ = static_cast<uint32_t>(feed_.ticks());
        frames_ = feed_.generator().frames_completed();
    }

    // A scan is active (running, or its last tick's sync word not yet cleared).
    bool active() const { return active_.load(std::memory_order_acquire); }
    // From the figures the tick keeps (the ticks stepped, the approach's).
    ScanState state() const {
        if (!started_) return ScanState::kNone;
        if (!active()) return ScanState::kEnded;
        return ticks_ < approach_ticks_ ? ScanState::kApproaching : ScanState::kScanning;
    }
    uint32_t approach_ticks() const { return approach_ticks_; }
    uint32_t ticks() const { return ticks_; }
    uint32_t frames_completed() const { return frames_; }

private:
    Multi& multi_;
    ScanFeed<T> feed_;
    std::atomic<bool> active_{false};
    std::atomic<bool> stop_request_{false};
    bool started_ = false;  // main loop only
    volatile uint32_t approach_ticks_ = 0, ticks_ = 0, frames_ = 0;
};

}  // namespace piezoloop::link
