// Anti-windup of the feedback's biquad cascade by conditional integration.
//
// When the output limiter clamps the command, the loop is open: whatever the
// controller's slow (near-integral) states accumulate then must be unwound
// after the reference is back in range, and the loop stays stuck at the limit
// meanwhile. Conditional integration (Åström & Hägglund, Advanced PID
// Control, ISA 2006, §3.5 "Integrator windup"; pid.hpp does the same for its
// integrator) stops the integration while the output is saturated and the
// error would drive it further into saturation. For a cascade of any form the
// "integration" is the update of all section states, so the rule becomes:
//
//   the limiter clamped the command above u_max (below u_min) on this tick,
//   and the error has the sign that moves the controller's low-frequency
//   output up (down)  ->  the cascade's states are put back to what they were
//   before this tick's sample (the sample's output was still used).
//
// "The sign that moves the output up" is the sign of the cascade's DC gain,
// prod_i sign(b0+b1+b2) * sign(1+a1+a2) over the sections (for a pole at
// z = 1, 1+a1+a2 = 0, the integrator's direction is the numerator's sign).
// A cascade with a zero at z = 1 (no DC gain) has no integral action to wind
// up: it gets no anti-windup (dc_sign() == 0) and its arithmetic is untouched.
//
// As soon as the error changes sign, the states move again, from where they
// were when the output first reached the limit: the loop leaves saturation
// on the first samples after the reference is back in range, instead of after
// the states have unwound what they gathered. Nothing changes while the
// limiter does not clamp, so unsaturated runs are bit-identical to a cascade
// without it. Slew limiting does not count as saturation (the command is
// reached a few samples later). Costs one copy of the states per tick, made
// before the ADC reading, and a copy back on clamped ticks only.
#pragma once

#include <cstdint>
#include <type_traits>

#include "piezoloop/biquad.hpp"
#include "piezoloop/sample.hpp"

namespace piezoloop {

template <class T, int MaxSections>
class CascadeAntiWindup {
public:
    using Cascade = BiquadCascade<T, MaxSections>;

    // The DC gain's sign of the cascade described by s[0..n). Never fails.
    constexpr void configure(const SosSection* s, int n) {
        int sign = 1;
        for (int i = 0; i < n; ++i) {
            const double num = s[i].b0 + s[i].b1 + s[i].b2;
            const double den = 1.0 + s[i].a1 + s[i].a2;
            if (num == 0.0) { sign = 0; break; }
            if (num < 0.0) sign = -sign;
            if (den < 0.0) sign = -sign;
        }
        dc_sign_ = static_cast<int8_t>(sign);
    }
    constexpr int dc_sign() const { return dc_sign_; }

    // Before the cascade's sample (the pipeline calls it before the reading,
    // outside the ADC-to-DAC span, and only when dc_sign() != 0): keep its
    // states. Unconditional: with dc_sign() 0 after() never restores them.
    constexpr void before(const Cascade& c) { c.save(held_); }
    // After the limiter: e is the cascade's input of this tick, clamp_direction
    // the limiter's (+1 above u_max, -1 below u_min, 0 none).
    constexpr void after(Cascade& c, T e, int clamp_direction) {
        if (clamp_direction == 0 || dc_sign_ == 0) return;
        int e_sign = 0;
        if constexpr (std::is_same_v<T, float>) e_sign = e > 0.0f ? 1 : (e < 0.0f ? -1 : 0);
        else e_sign = e.raw() > 0 ? 1 : (e.raw() < 0 ? -1 : 0);
        if (e_sign * dc_sign_ == clamp_direction) c.restore(held_);
    }

private:
    typename Cascade::Snapshot held_{};
    int8_t dc_sign_ = 0;
};

}  // namespace piezoloop
