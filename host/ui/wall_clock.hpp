// The host's wall clock in milliseconds since the Unix epoch: the time the
// console stamps on samples' arrival and frames, which the page compares
// with its own clock (host-to-screen latency).
#pragma once

#include <chrono>
#include <cstdint>

namespace piezoloop::ui {

inline int64_t wall_clock_ms() {
    return std::chrono::duration_cast<std::chrono::milliseconds>(std::chrono::system_clock::now().time_since_epoch())
        .count();
}

}  // namespace piezoloop::ui
