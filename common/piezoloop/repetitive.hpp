// Plug-in repetitive controller, docs/models.md, 'Repetitive control' (Shan2012 §2.1):
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
#include "piezoloop/q31.hpp"
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

// A first-order Q, y = (b0 + b1 z^-1) / (1 + a1 z^-1) -- the published one
// is -- run as a first-order section instead of a full biquad: half the work
// per tick, and on the Q31 side no variable 64-bit shifts. Configured only
// for sections with b2 = a2 = 0 (and, for Q31, coefficients below 1).
template <class T>
class FirstOrderSection;

// float: the biquad's direct form II transposed with s2 = 0, the same
// arithmetic in the same order (the biquad adds b2 x - a2 y = +-0 to s1,
// which changes nothing but possibly the sign of a zero). Only where the
// float cascade would itself choose DF2T for the section: a Q with its pole
// near z = 1 (a low cutoff at a high rate) runs as a cascade section in the
// delta-operator form instead.
template <>
class FirstOrderSection<float> {
public:
    static constexpr bool accepts(const SosSection& q) {
        return q.b2 == 0.0 && q.a2 == 0.0 && BiquadCascade<float, 1>::df2t_holds(q.b0, q.b1, q.b2, q.a1, q.a2);
    }
    void configure(const SosSection& q) {
        b0_ = static_cast<float>(q.b0);
        b1_ = static_cast<float>(q.b1);
        a1_ = static_cast<float>(q.a1);
    }
    void reset() { s1_ = 0.0f; }
    float apply(float x) {
        const float y = b0_ * x + s1_;
        s1_ = b1_ * x - a1_ * y;
        return y;
    }

private:
    float b0_ = 0.0f, b1_ = 0.0f, a1_ = 0.0f, s1_ = 0.0f;
};

// Q31: coefficients as plain Q31 (all below 1 in magnitude), products
// accumulated in int64 as Q62, the output the floor of the accumulator with
// first-order error feedback (the dropped residual re-enters the next
// accumulator, so truncation leaves no DC bias). The shift is the constant
// 31: a few instructions on a 32-bit core. |b0| + |b1| + |a1| < 2 (checked
// on the mantissas) keeps |acc| < 2^63.
template <>
class FirstOrderSection<Q31> {
public:
    static constexpr bool accepts(const SosSection& q) {
        if (!(q.b2 == 0.0 && q.a2 == 0.0)) return false;
        const auto mag = [](double v) { return v < 0.0 ? -v : v; };
        if (!(mag(q.b0) < 1.0 && mag(q.b1) < 1.0 && mag(q.a1) < 1.0)) return false;
        const auto m = [](double v) {
            const int64_t r = Q31::from_double(v).raw();
            return r < 0 ? -r : r;
        };
        return m(q.b0) + m(q.b1) + m(q.a1) <= (int64_t{1} << 32) - 2;
    }
    void configure(const SosSection& q) {
        b0_ = Q31::from_double(q.b0).raw();
        b1_ = Q31::from_double(q.b1).raw();
        a1_ = Q31::from_double(q.a1).raw();
    }
    void reset() { x1_ = y1_ = e1_ = 0; }
    Q31 apply(Q31 in) {
        const int32_t x = in.raw();
        int64_t acc = int64_t{b0_} * x + int64_t{b1_} * x1_ - int64_t{a1_} * y1_ + e1_;
        int64_t y = acc >> 31;  // floor
        uint32_t e = static_cast<uint32_t>(acc) & 0x7fffffffu;
        if (y > Q31::kMaxRaw) {
            y = Q31::kMaxRaw;
            e = 0;
        } else if (y < Q31::kMinRaw) {
            y = Q31::kMinRaw;
            e = 0;
        }
        x1_ = x;
        y1_ = static_cast<int32_t>(y);
        e1_ = e;
        return Q31::from_raw(y1_);
    }

private:
    int32_t b0_ = 0, b1_ = 0, a1_ = 0;
    int32_t x1_ = 0, y1_ = 0;
    uint32_t e1_ = 0;  // residual of the last output, Q62 units, [0, 2^31)
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
        // In 64 bits: m1 and m2 near 2^31 would wrap the difference to a
        // positive value in 32.
        if (int64_t{c.period_samples} - int64_t{c.m1} - int64_t{c.m2} < 1)
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
        first_order_ = FirstOrderSection<T>::accepts(c.q);
        if (first_order_) {
            q1_generator_.configure(c.q);
            q1_output_.configure(c.q);
        }
        generator_delay_ = c.period_samples - c.m1;
        output_delay_ = c.period_samples - c.m1 - c.m2;
        line_.set_window(c.period_samples);
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
        q1_generator_.reset();
        q1_output_.reset();
        phase_ = 0;
        x_ = sample_zero<T>();
    }

    // One tick: error in, RC correction out (to be added to the error).
    T apply(T e) {
        const T u_rc = prepare();
        push(e);
        return u_rc;
    }

    // apply() in two steps, for a tick that splits its work around the
    // reading: the correction depends only on the delay line's past (the
    // generator reads N - m1 samples back, the output N - m1 - m2 >= 1), so
    // prepare() computes it before the error is known and push(e) then
    // stores e + X. The same arithmetic in the same order as apply(); every
    // prepare() must be followed by one push() before the next.
    T prepare() {
        T lead;
        // With m2 = 0 both Q instances see the same sequence: skip the second.
        if (first_order_) {
            x_ = q1_generator_.apply(line_.past(generator_delay_));
            lead = output_delay_ == generator_delay_ ? x_ : q1_output_.apply(line_.past(output_delay_));
        } else {
            x_ = q_generator_.apply(line_.past(generator_delay_));
            lead = output_delay_ == generator_delay_ ? x_ : q_output_.apply(line_.past(output_delay_));
        }
        if constexpr (std::is_same_v<T, float>) {
            return k_rc_ * lead;
        } else {
            return q31_from_accumulator(int64_t{k_rc_mantissa_} * lead.raw(), 1);
        }
    }
    void push(T e) {
        line_.push(e + x_);
        if (++phase_ == config_.period_samples) phase_ = 0;
    }

    // True at the start of a period: where N, m1, m2, k_rc and Q may change
    // without cutting a learned period in the middle.
    bool at_period_boundary() const { return phase_ == 0; }
    const RepetitiveConfig& config() const { return config_; }

private:
    RepetitiveConfig config_{};
    BiquadCascade<T, 1> q_generator_{};
    BiquadCascade<T, 1> q_output_{};
    FirstOrderSection<T> q1_generator_{};  // used instead when Q is first order
    FirstOrderSection<T> q1_output_{};
    bool first_order_ = false;
    int generator_delay_ = 1;  // N - m1
    int output_delay_ = 1;     // N - m1 - m2
    float k_rc_ = 0.0f;
    int32_t k_rc_mantissa_ = 0;
    int phase_ = 0;
    T x_ = sample_zero<T>();  // the generator's output of this tick, between prepare() and push()
    // Last: the tick reaches the members above at small offsets.
    DelayLine<T, Capacity> line_{RepetitiveConfig{}.period_samples};
};

}  // namespace piezoloop
