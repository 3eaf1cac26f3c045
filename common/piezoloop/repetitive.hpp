// Plug-in repetitive controller, SPEC §6 (Shan2012 §2.1):
//
//   RC(z) = k_rc z^{m2} Q(z) z^{m1} z^{-N} / (1 - Q(z) z^{m1} z^{-N})
//   u = Gc(z) (1 + RC(z)) e       (the pipeline adds RC(e) to e before Gc)
//
// Realisation: with X = Q z^{m1-N} (e + X), the delay line stores
// s[k] = e[k] + X[k] and
//   X[k] = Q{ s[k - (N - m1)] }                    (the periodic signal generator)
//   u_rc[k] = k_rc X[k + m2] = k_rc Q{ s[k - (N - m1 - m2)] }
// The lead z^{m2} is obtained by reading the delay line m2 samples earlier
// through a second instance of Q, so everything stays causal while
// N - m1 - m2 >= 1. Both Q instances start from rest on the same zero history,
// so the second one is exactly the first one advanced by m2 samples.
#pragma once

#include "piezoloop/biquad.hpp"
#include "piezoloop/delay_line.hpp"
#include "piezoloop/sample.hpp"
#include "piezoloop/status.hpp"

namespace piezoloop {

struct RepetitiveConfig {
    int period_samples = 100;  // N: reference period in ticks
    int m1 = 6;                // lead compensating Q's phase lag
    int m2 = 0;                // lead compensating the closed loop's phase lag
    float k_rc = 0.8f;         // RC gain, (0, 2)
    // Q filter as one section. Published (Shan2012): 0.3558 / (z - 0.6442).
    SosSection q{0.0, 0.3558, 0.0, -0.6442, 0.0};
    bool operator==(const RepetitiveConfig&) const = default;
};

template <class T, int Capacity>
class RepetitiveController {
public:
    static constexpr int kMaxPeriod = Capacity;

    static constexpr Status validate(const RepetitiveConfig& c) {
        if (c.period_samples < 2 || c.period_samples > Capacity)
            return error("period_samples", "must be in [2, delay-line capacity]");
        if (c.m1 < 0) return error("m1", "must be >= 0");
        if (c.m2 < 0) return error("m2", "must be >= 0");
        if (c.period_samples - c.m1 - c.m2 < 1)
            return error("m2", "N - m1 - m2 must be >= 1 so the lead stays causal");
        if (!(c.k_rc > 0.0f && c.k_rc < 2.0f)) return error("k_rc", "must be in (0, 2)");
        return ok_status();
    }

    // Q is validated by the biquad; a rejected config leaves everything as it was.
    Status configure(const RepetitiveConfig& c) {
        if (const Status s = validate(c); !s.ok()) return s;
        BiquadCascade<T, 1> qa, qb;
        const SignalScale unit{1.0f};
        if (const Status s = qa.configure(&c.q, 1, unit, unit); !s.ok()) return error("q", s.message);
        qb = qa;
        config_ = c;
        q_generator_ = qa;
        q_output_ = qb;
        if constexpr (std::is_same_v<T, float>) {
            k_rc_ = c.k_rc;
        } else {
            k_rc_mantissa_ = quantize_mantissa(c.k_rc, 1);  // k_rc < 2: exponent 1
        }
        reset();
        return ok_status();
    }

    void reset() {
        line_.reset();
        q_generator_.reset();
        q_output_.reset();
        phase_ = 0;
    }

    // One tick: error in, RC correction out (to be added to the error).
    T apply(T e) {
        const int n = config_.period_samples;
        const T x = q_generator_.apply(line_.past(n - config_.m1));
        // With m2 = 0 both Q instances see the same sequence: skip the second.
        const T lead = config_.m2 == 0 ? x : q_output_.apply(line_.past(n - config_.m1 - config_.m2));
        line_.push(e + x);
        if (++phase_ == n) phase_ = 0;
        if constexpr (std::is_same_v<T, float>) {
            return k_rc_ * lead;
        } else {
            return q31_from_accumulator(int64_t{k_rc_mantissa_} * lead.raw(), 1);
        }
    }

    // True at the start of a period: where N, m1, m2, k_rc and Q may change
    // without cutting a learned period in the middle.
    bool at_period_boundary() const { return phase_ == 0; }
    const RepetitiveConfig& config() const { return config_; }

private:
    RepetitiveConfig config_{};
    DelayLine<T, Capacity> line_{};
    BiquadCascade<T, 1> q_generator_{};
    BiquadCascade<T, 1> q_output_{};
    float k_rc_ = 0.0f;
    int32_t k_rc_mantissa_ = 0;
    int phase_ = 0;
};

}  // namespace piezoloop
