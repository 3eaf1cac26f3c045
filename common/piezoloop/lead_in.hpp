// The lead-in of a measurement's excitation: its first samples blended
// from the value that leaves the command (or the reference) where it was
// into the excitation's own, so that no excitation starts with a jump.
//
//   d'(n) = from + (d(n) - from) * s(n / N),  n = 0 .. N - 1,
//
// with the approach's minimum-jerk s (approach.hpp), which starts and ends
// with zero slope. For an open-loop step, `from` is the command in effect
// and d the held level: the command moves to that level as a wave's
// approach does. For a multisine d moves, and the blend fades it in.
//
// N is the approach's speed bound for |d(0) - from| (at most
// kApproachFullScalesPerSecond full scales per second of the excitation's
// output scale, V or µm), capped at a quarter of the excitation's period:
// within the part that every measurement holds or discards first (a step's
// hold before its step, a frequency response's transient period, the first
// of the loops' cycles). N <= 1 means no lead-in: the excitation starts at
// once with the arithmetic it always had.
//
// The blend is the approach's (approach_detail::blend), its weight in Q31
// integers.
#pragma once

#include <cstdint>

#include "piezoloop/approach.hpp"
#include "piezoloop/q31.hpp"
#include "piezoloop/sample.hpp"
#include "piezoloop/trajectory.hpp"

namespace piezoloop {

template <class T>
class LeadIn {
public:
    // The next excitation's: its output scale, the loop rate, and its
    // period in samples (0: none, and so no lead-in). Main loop, while no
    // excitation runs.
    constexpr void prepare(SignalScale scale, float rate_Hz, uint64_t period_samples) {
        speed_ = Approach<T>(scale, rate_Hz);
        const uint64_t cap = period_samples / 4;
        max_ticks_ = cap > 0xffffffffu ? 0xffffffffu : static_cast<uint32_t>(cap);
        ticks_ = 0;
        n_ = 0;
        pending_ = true;
    }

    // At the excitation's first sample d0: the lead-in from `from`, if any.
    constexpr void begin(T from, T d0) {
        pending_ = false;
        uint32_t n = speed_.ticks_for(from, d0);
        if (n > max_ticks_) n = max_ticks_;
        if (n <= 1) return;
        from_ = from;
        ramp_ = trajectory_detail::make_ramp(n);
        ticks_ = n;
        n_ = 0;
    }

    constexpr bool pending() const { return pending_; }
    constexpr bool active() const { return n_ < ticks_; }
    constexpr uint32_t ticks() const { return ticks_; }  // N of the last lead-in begun (0: none)

    // The blended sample for the excitation's d of this tick.
    constexpr T blend(T d) {
        const int64_t s =
            approach_detail::min_jerk_q31(static_cast<uint32_t>(trajectory_detail::apply_ramp(ramp_, n_)));
        ++n_;
        return approach_detail::blend(from_, d, s);
    }

private:
    Approach<T> speed_{SignalScale{}, 1.0f};
    T from_{};
    trajectory_detail::Ramp ramp_{};
    uint32_t max_ticks_ = 0, ticks_ = 0, n_ = 0;
    bool pending_ = false;
};

}  // namespace piezoloop
