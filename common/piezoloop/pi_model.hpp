// Prandtl–Ishlinskii (PI) model, SPEC §2: a weighted sum of play operators.
//
//     f = input_gain * x + input_offset           (Shan2012's affine input)
//     y = p0 * f + sum_j weights[j] * F_{thresholds[j]}[f]
//
// The plain model of Janaideh2016 has input_gain 1 and offset 0. The same
// structure evaluates the analytic inverse (another PI model, pi_inverse.hpp)
// and Shan2012's generalised forward model and fitted inverse
// (pi_generalized.hpp), so one tight loop serves all hysteresis blocks.
#pragma once

#include <array>
#include <cstdint>

#include "piezoloop/det_math.hpp"
#include "piezoloop/play.hpp"
#include "piezoloop/sample.hpp"
#include "piezoloop/status.hpp"

namespace piezoloop {

inline constexpr int kMaxPlayOperators = 16;

struct PiModel {
    float input_gain = 1.0f;
    float input_offset = 0.0f;
    float p0 = 1.0f;  // weight of the linear (threshold-0) term
    int count = 0;    // number of play operators, 0..kMaxPlayOperators
    std::array<float, kMaxPlayOperators> thresholds{};  // ascending, >= 0, units of f
    std::array<float, kMaxPlayOperators> weights{};     // may be negative
    bool operator==(const PiModel&) const = default;
};

constexpr Status validate(const PiModel& m) {
    if (!is_finite(m.input_gain) || m.input_gain == 0.0f)
        return error("input_gain", "must be finite and non-zero");
    if (!is_finite(m.input_offset)) return error("input_offset", "must be finite");
    if (!is_finite(m.p0)) return error("p0", "must be finite");
    if (m.count < 0 || m.count > kMaxPlayOperators)
        return error("count", "must be in [0, 16]");
    for (int j = 0; j < m.count; ++j) {
        const float r = m.thresholds[static_cast<unsigned>(j)];
        if (!is_finite(r) || r < 0.0f) return error("thresholds", j, "must be finite and >= 0");
        if (j > 0 && !(r > m.thresholds[static_cast<unsigned>(j - 1)]))
            return error("thresholds", j, "must be strictly ascending");
        if (!is_finite(m.weights[static_cast<unsigned>(j)]))
            return error("weights", j, "must be finite");
    }
    return ok_status();
}

// Initial loading curve phi(r) = p0 r + sum_{r_i <= r} p_i (r - r_i), in f.
constexpr double loading_curve(const PiModel& m, double r) {
    double y = static_cast<double>(m.p0) * r;
    for (int j = 0; j < m.count; ++j) {
        const double rj = m.thresholds[static_cast<unsigned>(j)];
        if (rj <= r) y += static_cast<double>(m.weights[static_cast<unsigned>(j)]) * (r - rj);
    }
    return y;
}

// Per-sample evaluator of a PiModel for sample type T (float or Q31).
template <class T>
class PiOperator;

template <>
class PiOperator<float> {
public:
    Status configure(const PiModel& m, SignalScale /*in*/ = {}, SignalScale /*out*/ = {}) {
        if (const Status s = validate(m); !s.ok()) return s;
        model_ = m;
        reset();
        return ok_status();
    }
    void reset() { w_.fill(0.0f); }

    float apply(float x) {
        const float f = model_.input_gain * x + model_.input_offset;
        float y = model_.p0 * f;
        // A local bound lets GCC vectorise the play updates; reading
        // model_.count in the condition makes it reload it every iteration.
        const int n = model_.count;
        for (int j = 0; j < n; ++j) {
            const unsigned i = static_cast<unsigned>(j);
            w_[i] = play(f, model_.thresholds[i], w_[i]);
            y = y + model_.weights[i] * w_[i];
        }
        return y;
    }
    const PiModel& model() const { return model_; }
    float state(int j) const { return w_[static_cast<unsigned>(j)]; }

private:
    PiModel model_{};
    std::array<float, kMaxPlayOperators> w_{};
};

// Q31: thresholds and play states are Q31 in the input scale; the output sum
// sum m_j * w_j is accumulated in int64 with one block exponent for p0 and all
// weights (already converted by in.full_scale / out.full_scale), and rounded
// to Q31 once.
template <>
class PiOperator<Q31> {
public:
    Status configure(const PiModel& m, SignalScale in, SignalScale out) {
        if (const Status s = validate(m); !s.ok()) return s;
        if (!(in.full_scale > 0.0f) || !(out.full_scale > 0.0f))
            return error("full_scale", "must be > 0");
        count_ = m.count;
        const double gain = SignalScale::sample_gain<Q31>(1.0, in, out);
        std::array<double, kMaxPlayOperators + 1> c{};
        c[0] = m.p0 * gain;
        for (int j = 0; j < m.count; ++j) {
            const unsigned i = static_cast<unsigned>(j);
            c[i + 1] = m.weights[i] * gain;
            r_[i] = Q31::from_double(static_cast<double>(m.thresholds[i]) / in.full_scale);
        }
        exponent_ = block_exponent(c.data(), m.count + 1);
        p0_ = quantize_mantissa(c[0], exponent_);
        for (int j = 0; j < m.count; ++j)
            p_[static_cast<unsigned>(j)] = quantize_mantissa(c[static_cast<unsigned>(j) + 1], exponent_);
        // Affine input: gain with its own exponent, offset as a Q31 sample.
        const double a = m.input_gain;
        input_exponent_ = block_exponent(&a, 1);
        input_gain_ = quantize_mantissa(a, input_exponent_);
        input_offset_ = Q31::from_double(static_cast<double>(m.input_offset) / in.full_scale);
        identity_input_ = m.input_gain == 1.0f && m.input_offset == 0.0f;
        reset();
        return ok_status();
    }
    void reset() { w_.fill(Q31{}); }

    Q31 apply(Q31 x) {
        Q31 f = x;
        if (!identity_input_)
            f = q31_from_accumulator(int64_t{input_gain_} * x.raw(), input_exponent_) + input_offset_;
        int64_t acc = int64_t{p0_} * f.raw();
        for (int j = 0; j < count_; ++j) {
            const unsigned i = static_cast<unsigned>(j);
            w_[i] = play(f, r_[i], w_[i]);
            acc += int64_t{p_[i]} * w_[i].raw();
        }
        return q31_from_accumulator(acc, exponent_);
    }
    Q31 state(int j) const { return w_[static_cast<unsigned>(j)]; }

private:
    int count_ = 0;
    int exponent_ = 0;
    int32_t p0_ = 0;
    std::array<int32_t, kMaxPlayOperators> p_{};
    std::array<Q31, kMaxPlayOperators> r_{};
    std::array<Q31, kMaxPlayOperators> w_{};
    bool identity_input_ = true;
    int input_exponent_ = 0;
    int32_t input_gain_ = 0;
    Q31 input_offset_{};
};

}  // namespace piezoloop
