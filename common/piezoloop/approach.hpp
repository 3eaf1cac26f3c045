// The approach: a smooth move of the reference from where it is to a
// trajectory's first point, so that no trajectory starts with a jump of the
// reference (which would ring the stage's modes and saturate the command).
//
//   r(t) = from + (to - from) * s(t / T),   s(x) = 10 x^3 - 15 x^4 + 6 x^5
//
// s is the minimum-jerk (quintic) profile (Flash & Hogan, J. Neurosci. 5,
// 1985): it rises from 0 to 1 with zero velocity and zero acceleration at
// both ends, so r and its first two derivatives are continuous where the
// move starts. Its peak slope is s'(1/2) = 15/8, so the peak velocity is
// 15/8 |to - from| / T.
//
// Speed: the peak velocity is at most kApproachFullScalesPerSecond position
// full scales per second (the sensor's range: 10 x 50 um = 500 um/s on the
// boards). T is the shortest whole number N of ticks that keeps it there:
//
//   N = ceil(|to - from| / unit),   unit = 8/15 * v_max / rate   (um per tick)
//
// Samples n = 1 .. N-1 (x = n / N) are the approach; sample N is the
// trajectory's first (exactly `to`), sample 0 the reference before it
// (`from`). A step between two samples is the mean velocity over a tick, so
// no step is larger than v_max / rate. N <= 1, a distance that v_max
// allows within one tick (zero included), means no approach at all: the
// trajectory starts at once and the tick's arithmetic is what it was.
//
// Arithmetic: x = n / N is the trajectory's linear ramp (phase LSBs,
// trajectory_detail::make_ramp, at most 2 LSB of 2^-32 below the exact
// value) and s(x) is computed in Q31 integer arithmetic, so the float and
// the Q31 approach share their shape bit for bit and are deterministic on
// every target. Shape error: below 2^-26 (the truncations of x^3, up to
// 2 Q31 LSB, weigh with the polynomial, up to 10). Output: float
// from + (to - from) * s; Q31 the convex combination
// from * (1 - s) + to * s in 64 bits, rounded (within [from, to]).
#pragma once

#include <cstdint>
#include <type_traits>

#include "piezoloop/q31.hpp"
#include "piezoloop/sample.hpp"
#include "piezoloop/trajectory.hpp"

namespace piezoloop {

// Peak velocity of an approach, in position full scales per second.
inline constexpr double kApproachFullScalesPerSecond = 10.0;

namespace approach_detail {

// s(x) for x = p / 2^32 (p < 2^32), as Q31 raw in [0, 2^31].
constexpr int64_t min_jerk_q31(uint32_t p) {
    const uint64_t x = p >> 1;                  // Q31
    const uint64_t x2 = (x * x) >> 31;          // Q31
    const uint64_t x3 = (x2 * x) >> 31;         // Q31
    // 10 - 15 x + 6 x^2, formed in Q31 (in [1, 10] for x in [0, 1]) and
    // kept in Q29, below 2^32.4, so that x3 * poly < 2^63.4 fits.
    const uint64_t poly = ((uint64_t{10} << 31) + 6 * x2 - 15 * x) >> 2;
    return static_cast<int64_t>((x3 * poly) >> 29);
}

// from + (to - from) s for the weight s of min_jerk_q31 (Q31 raw in
// [0, 2^31]): float as written; Q31 the convex combination
// from (1 - s) + to s in 64 bits, rounded (within [from, to]).
template <class T>
constexpr T blend(T from, T to, int64_t s) {
    if constexpr (std::is_same_v<T, float>) {
        return from + (to - from) * (static_cast<float>(s) * 0x1p-31f);
    } else {
        const int64_t v = int64_t{from.raw()} * ((int64_t{1} << 31) - s) + int64_t{to.raw()} * s;
        return Q31::from_raw(static_cast<int32_t>((v + (int64_t{1} << 30)) >> 31));
    }
}

}  // namespace approach_detail

template <class T>
class Approach {
    static_assert(is_sample_type_v<T>, "Approach<T>: T is float or Q31");
    static constexpr bool kFloat = std::is_same_v<T, float>;

public:
    // position: µm <-> Q31 of the reference; rate_Hz: the loop rate (> 0).
    constexpr Approach(SignalScale position, float rate_Hz) {
        const double per_tick = 8.0 / 15.0 * kApproachFullScalesPerSecond / static_cast<double>(rate_Hz);
        if constexpr (kFloat) {
            unit_ = static_cast<float>(per_tick * static_cast<double>(position.full_scale));
        } else {
            const double raw = per_tick * 2147483648.0;  // Q31 raw per tick: the full scale cancels
            unit_ = raw < 1.0 ? 1u : (raw > 4294967295.0 ? 0xffffffffu : static_cast<uint32_t>(raw));
        }
    }

    // The next approach, to `to`, starts at its first sample (begin()).
    // Main loop, while the tick does not read this one.
    constexpr void request(T to) {
        to_ = to;
        state_ = State::kPending;
    }
    // Pending or moving: the tick asks for samples.
    constexpr bool active() const { return state_ != State::kIdle; }
    constexpr bool pending() const { return state_ == State::kPending; }
    constexpr bool moving() const { return state_ == State::kMoving; }

    // N for a move from `from` to `to`: 0 or 1 mean no approach.
    constexpr uint32_t ticks_for(T from, T to) const {
        if constexpr (kFloat) {
            const float d = to - from;
            const float dist = d < 0.0f ? -d : d;
            if (!(dist > unit_)) return dist > 0.0f ? 1u : 0u;  // NaN: none
            const float n = dist / unit_;
            if (!(n < 2147483648.0f)) return 0x80000000u;  // slower than the bound, never faster
            uint32_t ticks = static_cast<uint32_t>(n);
            if (static_cast<float>(ticks) < n) ++ticks;
            return ticks;
        } else {
            const int64_t d = int64_t{to.raw()} - int64_t{from.raw()};
            const uint32_t dist = static_cast<uint32_t>(d < 0 ? -d : d);  // < 2^32
            return dist / unit_ + (dist % unit_ != 0 ? 1u : 0u);
        }
    }

    // Starts the requested approach from `from`; false (and idle) if it
    // takes no tick (N <= 1).
    constexpr bool begin(T from) { return begin(from, to_); }
    // Starts an approach from `from` to `to`.
    constexpr bool begin(T from, T to) {
        const uint32_t n = ticks_for(from, to);
        if (n <= 1) {
            state_ = State::kIdle;
            return false;
        }
        from_ = from;
        to_ = to;
        ramp_ = trajectory_detail::make_ramp(n);
        ticks_ = n;
        n_ = 0;
        state_ = State::kMoving;
        return true;
    }

    // The next sample (n = 1 .. N - 1); idle after the last one.
    constexpr T step() {
        ++n_;
        if (n_ + 1 >= ticks_) state_ = State::kIdle;
        const int64_t s = approach_detail::min_jerk_q31(
            static_cast<uint32_t>(trajectory_detail::apply_ramp(ramp_, n_)));
        return approach_detail::blend(from_, to_, s);
    }

    constexpr uint32_t ticks() const { return ticks_; }  // N of the last move begun
    constexpr float unit() const {  // largest step per tick in sample units (Q31: raw LSBs)
        if constexpr (kFloat) return unit_;
        else return static_cast<float>(unit_);
    }

private:
    enum class State : uint8_t { kIdle, kPending, kMoving };
    std::conditional_t<kFloat, float, uint32_t> unit_{};
    T from_{}, to_{};
    trajectory_detail::Ramp ramp_{};
    uint32_t ticks_ = 0, n_ = 0;
    State state_ = State::kIdle;
};

}  // namespace piezoloop
