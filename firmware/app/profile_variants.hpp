// NOT USED BY THE FIRMWARE. (The float max/min and unrolling proposals are
// applied in the core since; the variants keep the core's four-lane sum so
// they stay comparable bit for bit.) Candidate rewrites of the play-operator loop of
// common/piezoloop/pi_model.hpp (PiOperator<T>::apply), kept here only so
// that profile_blocks.elf can measure what they would save and check, tick
// by tick on the reference run, that they give bit-identical outputs. They
// are proposals for the core's owner (docs/boards.md, "Budget"); common/ is
// not changed by the firmware.
//
// Float: max/min of the play operator as IEEE maxNum/minNum
// (__builtin_fmaxf/fminf), which the FPv5 FPU of the Cortex-M7 executes as
// one VMAXNM/VMINNM each instead of VCMP + VMRS + IT + VMOV. Identical to
// the `a < b ? b : a` form for every non-NaN input: the two can only differ
// on the sign of a zero result when both operands are zeros of opposite
// sign, and with thresholds r >= 0 and the state starting at +0 no -0 ever
// reaches max/min unless the input itself is -0 with r = 0, where both
// forms return -0. (On x86 the builtins are libm calls: the host would keep
// the ternary, under a per-target macro.)
//
// Q31: the same operator without the int64 saturating Q31 operators:
// u + r and u - r in wrapping int32, saturated by a wrap test (r >= 0), then
// clamp(w, lo, hi) -- exactly max(u - r, min(u + r, w)) with saturating
// arithmetic, since lo <= hi. Keeping everything int32 also lets GCC use
// one SMLAL for the weighted sum (with an int64 clamp it multiplies 64x64).
#pragma once

#include <array>
#include <cstdint>

#include "piezoloop/biquad.hpp"
#include "piezoloop/pi_model.hpp"

namespace piezoloop::fw::variants {

// Float, runtime operator count (same loop shape as the core).
class PiFloatMinMax {
public:
    bool configure(const PiModel& m) {
        m_ = m;
        w_.fill(0.0f);
        return true;
    }
    float apply(float x) {
        const float f = m_.input_gain * x + m_.input_offset;
        // The core's summation order: four lanes, operator j in lane j % 4.
        float lane[4] = {0.0f, 0.0f, 0.0f, 0.0f};
        for (int j = 0; j < m_.count; ++j) {
            const unsigned i = static_cast<unsigned>(j);
            w_[i] = __builtin_fmaxf(f - m_.thresholds[i], __builtin_fminf(f + m_.thresholds[i], w_[i]));
            const float term = m_.weights[i] * w_[i];
            lane[j % 4] = j < 4 ? term : lane[j % 4] + term;
        }
        return m_.p0 * f + ((lane[0] + lane[1]) + (lane[2] + lane[3]));  // count >= 4
    }

private:
    PiModel m_{};
    std::array<float, kMaxPlayOperators> w_{};
};

// Float, compile-time operator count: fully unrolled, no loop overhead.
template <int N>
class PiFloatMinMaxUnrolled {
public:
    bool configure(const PiModel& m) {
        if (m.count != N) return false;
        gain_ = m.input_gain;
        offset_ = m.input_offset;
        p0_ = m.p0;
        for (int j = 0; j < N; ++j) {
            r_[static_cast<unsigned>(j)] = m.thresholds[static_cast<unsigned>(j)];
            p_[static_cast<unsigned>(j)] = m.weights[static_cast<unsigned>(j)];
        }
        w_.fill(0.0f);
        return true;
    }
    float apply(float x) {
        static_assert(N >= 4, "the lane sum below assumes four lanes in use");
        const float f = gain_ * x + offset_;
        float lane[4] = {0.0f, 0.0f, 0.0f, 0.0f};
#pragma GCC unroll 16
        for (int j = 0; j < N; ++j) {
            const unsigned i = static_cast<unsigned>(j);
            w_[i] = __builtin_fmaxf(f - r_[i], __builtin_fminf(f + r_[i], w_[i]));
            const float term = p_[i] * w_[i];
            lane[j % 4] = j < 4 ? term : lane[j % 4] + term;
        }
        return p0_ * f + ((lane[0] + lane[1]) + (lane[2] + lane[3]));
    }

private:
    float gain_ = 1.0f, offset_ = 0.0f, p0_ = 1.0f;
    std::array<float, N> r_{}, p_{}, w_{};
};

// Q31 with the int64 clamp; coefficients taken from a configured core
// operator so the comparison is exact (same mantissas and exponent).
class PiQ31Clamp {
public:
    bool configure(const PiModel& m, SignalScale in, SignalScale out) {
        // Mirror PiOperator<Q31>::configure (identity input only).
        if (m.input_gain != 1.0f || m.input_offset != 0.0f) return false;
        count_ = m.count;
        const double gain = SignalScale::sample_gain<Q31>(1.0, in, out);
        std::array<double, kMaxPlayOperators + 1> c{};
        c[0] = m.p0 * gain;
        for (int j = 0; j < m.count; ++j) {
            const unsigned i = static_cast<unsigned>(j);
            c[i + 1] = m.weights[i] * gain;
            r_[i] = Q31::from_double(static_cast<double>(m.thresholds[i]) / in.full_scale).raw();
        }
        exponent_ = block_exponent(c.data(), m.count + 1);
        p0_ = quantize_mantissa(c[0], exponent_);
        for (int j = 0; j < m.count; ++j)
            p_[static_cast<unsigned>(j)] = quantize_mantissa(c[static_cast<unsigned>(j) + 1], exponent_);
        w_.fill(0);
        return true;
    }
    Q31 apply(Q31 x) {
        const int32_t u = x.raw();
        int64_t acc = int64_t{p0_} * u;
        for (int j = 0; j < count_; ++j) {
            const unsigned i = static_cast<unsigned>(j);
            // u + r and u - r in wrapping 32-bit arithmetic (r >= 0), then
            // saturated by the wrap test: only int32 values, so the
            // product below stays one 32x32->64 multiply-accumulate.
            const int32_t r = r_[i];
            int32_t hi = static_cast<int32_t>(static_cast<uint32_t>(u) + static_cast<uint32_t>(r));
            int32_t lo = static_cast<int32_t>(static_cast<uint32_t>(u) - static_cast<uint32_t>(r));
            if (hi < u) hi = Q31::kMaxRaw;
            if (lo > u) lo = Q31::kMinRaw;
            int32_t w = w_[i];
            if (w < lo) w = lo;
            if (w > hi) w = hi;
            w_[i] = w;
            acc += int64_t{p_[i]} * w;
        }
        return q31_from_accumulator(acc, exponent_);
    }

private:
    int count_ = 0;
    int exponent_ = 0;
    int32_t p0_ = 0;
    std::array<int32_t, kMaxPlayOperators> p_{}, r_{}, w_{};
};

// Plain float32 direct form II transposed sections, unrolled for a count
// fixed at compile time: the form the core's float cascade used before its
// delta-operator sections (biquad.hpp), kept as the cost comparison point.
// Not a drop-in: it cannot hold poles near z = 1, so its output differs
// from the core's (mismatches_vs_core counts the ticks).
template <int N>
class SosFloatDf2t {
public:
    bool configure(const SosSection* sections, int count) {
        if (count != N) return false;
        for (int i = 0; i < N; ++i) {
            const SosSection& q = sections[i];
            c_[static_cast<unsigned>(i)] = {static_cast<float>(q.b0), static_cast<float>(q.b1),
                                            static_cast<float>(q.b2), static_cast<float>(q.a1),
                                            static_cast<float>(q.a2)};
        }
        s_ = {};
        return true;
    }
    float apply(float x) {
#pragma GCC unroll 8
        for (int i = 0; i < N; ++i) {
            const Coef& c = c_[static_cast<unsigned>(i)];
            State& st = s_[static_cast<unsigned>(i)];
            const float y = c.b0 * x + st.s1;
            st.s1 = c.b1 * x - c.a1 * y + st.s2;
            st.s2 = c.b2 * x - c.a2 * y;
            x = y;
        }
        return x;
    }

private:
    struct Coef {
        float b0, b1, b2, a1, a2;
    };
    struct State {
        float s1 = 0.0f, s2 = 0.0f;
    };
    std::array<Coef, N> c_{};
    std::array<State, N> s_{};
};

// The delta-operator form of biquad.hpp for every section, unrolled, no
// per-section dispatch: the cost of that form alone. Its output differs
// from the core's where the core runs a section in DF2T.
template <int N>
class SosFloatDelta {
public:
    bool configure(const SosSection* sections, int count) {
        if (count != N) return false;
        for (int i = 0; i < N; ++i) {
            const SosSection& q = sections[i];
            const double c1 = q.a1 + 2.0, c0 = c1 + (q.a2 - 1.0);
            c_[static_cast<unsigned>(i)] = {static_cast<float>(q.b0),
                                            static_cast<float>((2.0 * q.b0 + q.b1) - q.b0 * c1),
                                            static_cast<float>((q.b0 + q.b1 + q.b2) - q.b0 * c0),
                                            static_cast<float>(c1), static_cast<float>(c0)};
        }
        s_ = {};
        return true;
    }
    float apply(float x) {
#pragma GCC unroll 8
        for (int i = 0; i < N; ++i) {
            const Coef& c = c_[static_cast<unsigned>(i)];
            State& st = s_[static_cast<unsigned>(i)];
            const float y = c.b0 * x + st.s1;
            const float i1 = ((st.s2 + c.g1 * x) - c.c1 * st.s1) + st.r1;
            const float i2 = (c.g0 * x - c.c0 * st.s1) + st.r2;
            const float t1 = st.s1 + i1;
            st.r1 = i1 - (t1 - st.s1);
            st.s1 = t1;
            const float t2 = st.s2 + i2;
            st.r2 = i2 - (t2 - st.s2);
            st.s2 = t2;
            x = y;
        }
        return x;
    }

private:
    struct Coef {
        float b0, g1, g0, c1, c0;
    };
    struct State {
        float s1 = 0.0f, s2 = 0.0f, r1 = 0.0f, r2 = 0.0f;
    };
    std::array<Coef, N> c_{};
    std::array<State, N> s_{};
};

}  // namespace piezoloop::fw::variants
