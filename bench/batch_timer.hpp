// Manual timing of batches of one-sample calls.
//
// Each benchmark iteration times one batch of calls with steady_clock and
// hands the time to Google Benchmark (UseManualTime), so work that belongs to
// the harness and not to the tick (draining the recorder, restarting the
// replayed trace) runs between batches, untimed, without PauseTiming's
// per-call cost (two process-CPU-time clock reads, a system call each) landing
// in the measurement. A batch is hundreds of calls, so the two vDSO clock
// reads around it add well under 0.1 ns per call.
//
// The figure reported per call is the MEDIAN over batches of the batch's
// time per call. On a shared 2-core machine a batch (~10 µs) is now and then
// preempted or interrupted for far longer than it takes; such a batch is an
// outlier that the median ignores and a mean (Google Benchmark's Time column,
// total time / batches) does not.
#pragma once

#include <benchmark/benchmark.h>

#include <algorithm>
#include <chrono>
#include <cstdint>
#include <vector>

namespace bench {

class BatchTimer {
public:
    BatchTimer() { per_unit_ns_.reserve(1 << 16); }

    // Times body() as one benchmark iteration that did `units` units of work.
    template <class Body>
    void time(benchmark::State& state, int64_t units, Body&& body) {
        const auto t0 = std::chrono::steady_clock::now();
        body();
        const auto t1 = std::chrono::steady_clock::now();
        const double s = std::chrono::duration<double>(t1 - t0).count();
        state.SetIterationTime(s);
        if (units > 0) per_unit_ns_.push_back(s * 1e9 / static_cast<double>(units));
    }

    // Median over batches of ns per unit (0 if nothing was timed).
    double ns_per_unit() {
        if (per_unit_ns_.empty()) return 0.0;
        const auto mid = per_unit_ns_.begin() + static_cast<std::ptrdiff_t>(per_unit_ns_.size() / 2);
        std::nth_element(per_unit_ns_.begin(), mid, per_unit_ns_.end());
        return *mid;
    }

private:
    std::vector<double> per_unit_ns_;
};

}  // namespace bench
