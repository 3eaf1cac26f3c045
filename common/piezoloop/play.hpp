// Play (backlash) and stop operators, docs/models.md, 'Play and stop operators'. Exact per sample: no
// integration, so they are rate independent by construction.
#pragma once

#include <cstdint>

#include "piezoloop/fpv5.hpp"
#include "piezoloop/sample.hpp"

namespace piezoloop {

// w[k] = max(u[k] - r, min(u[k] + r, w[k-1])), threshold r >= 0.
template <class T>
constexpr T play(T u, T r, T w_prev) {
    return max(u - r, min(u + r, w_prev));
}

// Float: on the Cortex-M7's FPv5 (the only Armv7E-M FPU with double
// precision) IEEE maxNum/minNum are one VMAXNM/VMINNM instruction each,
// against compare + flag transfer + conditional move for the ternary form.
// Both give the same bits for every non-NaN input: they could differ only in
// the sign of a zero from max(-0, +0), and with r >= 0 and a +0 initial state
// no -0 reaches them. NaN never reaches a play operator: the pipeline refuses
// non-finite setpoints and the trajectory generator is finite. On x86 these
// builtins are library calls, so the host keeps the ternary form.
// Always inlined: two instructions, inside unrolled loops whose size would
// otherwise make GCC call it.
#if PIEZOLOOP_FPV5
[[gnu::always_inline]] constexpr float play(float u, float r, float w_prev) {
    return __builtin_fmaxf(u - r, __builtin_fminf(u + r, w_prev));
}
#endif

// Q31: u + r and u - r in wrapping 32-bit arithmetic, saturated by the wrap
// test (r >= 0), then w clamped to [lo, hi] -- exactly the saturating
// max(u - r, min(u + r, w)), since lo <= hi, but all in int32, which keeps the
// caller's weighted sum a single 32x32 -> 64 multiply-accumulate.
constexpr Q31 play(Q31 u, Q31 r, Q31 w_prev) {
    const int32_t x = u.raw();
    int32_t hi = static_cast<int32_t>(static_cast<uint32_t>(x) + static_cast<uint32_t>(r.raw()));
    int32_t lo = static_cast<int32_t>(static_cast<uint32_t>(x) - static_cast<uint32_t>(r.raw()));
    if (hi < x) hi = Q31::kMaxRaw;
    if (lo > x) lo = Q31::kMinRaw;
    int32_t w = w_prev.raw();
    if (w > hi) w = hi;
    if (w < lo) w = lo;
    return Q31::from_raw(w);
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
