// Play (backlash) and stop operators, SPEC §1. Exact per sample: no
// integration, so they are rate independent by construction.
#pragma once

#include "piezoloop/sample.hpp"

namespace piezoloop {

// w[k] = max(u[k] - r, min(u[k] + r, w[k-1])). For Q31 the saturating add and
// subtract keep the meaning: if u + r saturates, min() returns w unchanged,
// which is what the exact value would give for any w in range.
template <class T>
constexpr T play(T u, T r, T w_prev) {
    return max(u - r, min(u + r, w_prev));
}

// One play operator with its state; the stop operator is its complement,
// s = u - w, so stop + play = input and |s| <= r.
template <class T>
class PlayOperator {
public:
    constexpr PlayOperator() = default;
    constexpr explicit PlayOperator(T threshold) : r_(threshold) {}

    // Janaideh2016's initial state for a first input u0 is
    // max(u0 - r, min(u0 + r, 0)), i.e. the play run once from w = 0.
    constexpr void reset(T w0 = sample_zero<T>()) { w_ = w0; }

    constexpr T apply(T u) { return w_ = play(u, r_, w_); }
    constexpr T stop_of(T u) const { return u - w_; }  // stop output for the last u
    constexpr T state() const { return w_; }
    constexpr T threshold() const { return r_; }

private:
    T r_ = sample_zero<T>();
    T w_ = sample_zero<T>();
};

}  // namespace piezoloop
