// Prandtl–Ishlinskii (PI) model (docs/models.md, 'Prandtl–Ishlinskii model'):
// a weighted sum of play operators.
//
//     g(x) = x + sum_i dead_zone_weights[i] * max(x - dead_zone_thresholds[i], 0)
//     f = input_gain * g(x) + input_offset        (Shan2012's affine input)
//     y = p0 * f + sum_j weights[j] * F_{thresholds[j]}[f]
//
// g, a superposition of one-sided dead zones (none by default: g(x) = x),
// is the compensator of Kuhnen's modified PI model y = S(c + PI[u]): S's
// inverse on the reference, then the PI inverse (K. Kuhnen, European Journal
// of Control 9(4), 2003; docs/identification.md).
// The plain model of Janaideh2016 has input_gain 1 and offset 0. The same
// structure evaluates the analytic inverse (another PI model, pi_inverse.hpp)
// and Shan2012's generalised forward model and fitted inverse
// (pi_generalized.hpp), so one tight loop serves all hysteresis blocks.
#pragma once

#include <array>
#include <cstddef>
#include <cstdint>
#include <utility>

#include "piezoloop/det_math.hpp"
#include "piezoloop/fpv5.hpp"
#include "piezoloop/play.hpp"
#include "piezoloop/sample.hpp"
#include "piezoloop/status.hpp"

namespace piezoloop {

inline constexpr int kMaxPlayOperators = 16;
inline constexpr int kMaxDeadZones = 8;

// A superposition of one-sided dead zones, x + sum_i w_i max(x - d_i, 0)
// (Kuhnen 2003): the modified PI's input map g (PiModel) and a stage's
// output map S (plant.hpp). Its fields' names, for the errors.
struct DeadZoneFields {
    const char* count;
    const char* thresholds;
    const char* weights;
    const char* not_increasing;  // the message for a weight that makes a slope <= 0
};

// count in [0, 8]; thresholds finite and strictly ascending; weights finite,
// each keeping the slope 1 + w_1 + ... + w_i > 0 (an increasing map, which
// has an inverse of the same form).
constexpr Status validate_dead_zones(int count, const std::array<float, kMaxDeadZones>& thresholds,
                                     const std::array<float, kMaxDeadZones>& weights, const DeadZoneFields& f) {
    if (count < 0 || count > kMaxDeadZones) return error(f.count, "must be in [0, 8]");
    double slope = 1.0;
    for (int i = 0; i < count; ++i) {
        const unsigned k = static_cast<unsigned>(i);
        const float d = thresholds[k];
        if (!is_finite(d)) return error(f.thresholds, i, "must be finite");
        if (i > 0 && !(d > thresholds[k - 1])) return error(f.thresholds, i, "must be strictly ascending");
        if (!is_finite(weights[k])) return error(f.weights, i, "must be finite");
        slope += static_cast<double>(weights[k]);
        if (!(slope > 0.0)) return error(f.weights, i, f.not_increasing);
    }
    return ok_status();
}

// The map in float, in threshold order: the arithmetic the float operator
// and the stage run.
inline float dead_zone_sum(int count, const std::array<float, kMaxDeadZones>& thresholds,
                           const std::array<float, kMaxDeadZones>& weights, float x) {
    float g = x;
    for (int i = 0; i < count; ++i) {
        const unsigned k = static_cast<unsigned>(i);
        const float e = x - thresholds[k];
        if (e > 0.0f) g = g + weights[k] * e;
    }
    return g;
}

struct PiModel {
    float input_gain = 1.0f;
    float input_offset = 0.0f;
    float p0 = 1.0f;  // weight of the linear (threshold-0) term
    int count = 0;    // number of play operators, 0..kMaxPlayOperators
    std::array<float, kMaxPlayOperators> thresholds{};  // ascending, >= 0, units of f
    std::array<float, kMaxPlayOperators> weights{};     // may be negative
    int dead_zones = 0;  // of the input map g, 0..kMaxDeadZones; 0: g(x) = x
    std::array<float, kMaxDeadZones> dead_zone_thresholds{};  // strictly ascending, units of x
    std::array<float, kMaxDeadZones> dead_zone_weights{};     // g's slope 1 + the weights so far stays > 0
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
    if (const Status s = validate_dead_zones(m.dead_zones, m.dead_zone_thresholds, m.dead_zone_weights,
                                             {"dead_zones", "dead_zone_thresholds", "dead_zone_weights",
                                              "must keep the input map increasing: 1 + the weights up to it > 0"});
        !s.ok())
        return s;
    return ok_status();
}

// g(x) of the input map in float, in threshold order: the arithmetic the
// float operator runs.
inline float dead_zone_map(const PiModel& m, float x) {
    return dead_zone_sum(m.dead_zones, m.dead_zone_thresholds, m.dead_zone_weights, x);
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

// x86-64 (SSE2) hosts evaluate the float operator's four summation lanes
// as one vector; every other target runs the scalar loop. Both are the same
// IEEE operations in the same order.
#if defined(__SSE2__) && defined(__GNUC__)
#define PIEZOLOOP_PI_VECTOR_LANES 1
#else
#define PIEZOLOOP_PI_VECTOR_LANES 0
#endif
// On a Cortex-M7 with FPv5 (fpv5.hpp) one VLDM loads a group's thresholds,
// states and weights (12 registers) and one VSTM stores its states, instead
// of three VLDR and one VSTR per operator; the arithmetic is the C++ below.

// Per-sample evaluator of a PiModel for sample type T (float or Q31).
template <class T>
class PiOperator;

template <>
class PiOperator<float> {
public:
    Status configure(const PiModel& m, SignalScale /*in*/ = {}, SignalScale /*out*/ = {}) {
        if (const Status s = validate(m); !s.ok()) return s;
        model_ = m;
        identity_input_ = m.input_gain == 1.0f && m.input_offset == 0.0f && m.dead_zones == 0;
        groups_ = {};
        for (int j = 0; j < m.count; ++j) {
            const unsigned i = static_cast<unsigned>(j);
            groups_[i / 4].r[i % 4] = m.thresholds[i];
            groups_[i / 4].p[i % 4] = m.weights[i];
        }
        reset();
        return ok_status();
    }
    void reset() {
        for (Group& g : groups_) g.w.fill(0.0f);
    }
    // The states after coming up to t from far below (pi_start_state.hpp):
    // w_j = t - r_j, in the play domain. The next apply() takes them to x.
    void start_ascended_to(float t) {
        for (int j = 0; j < model_.count; ++j) {
            const unsigned i = static_cast<unsigned>(j);
            groups_[i / 4].w[i % 4] = t - groups_[i / 4].r[i % 4];
        }
    }

    // Dispatches once on the operator count to a fully unrolled loop (no
    // per-operator loop overhead: -20 % of the tick's largest block on the
    // Cortex-M7); the arithmetic and its order are those of the plain loop.
    float apply(float x);
    const PiModel& model() const { return model_; }
    float state(int j) const {
        const unsigned i = static_cast<unsigned>(j);
        return groups_[i / 4].w[i % 4];
    }

private:
    // Operators 4g .. 4g + 3, interleaved by group so that one group's
    // thresholds, weights and states are 48 contiguous bytes: loaded at
    // once (one vector on the host, one VLDM on the Cortex-M7).
    struct Group {
        std::array<float, 4> r{};  // thresholds
        std::array<float, 4> p{};  // weights
        std::array<float, 4> w{};  // play states
    };
    static_assert(sizeof(Group) == 12 * sizeof(float));
    static_assert(kMaxPlayOperators % 4 == 0, "the operators fill whole groups");

    // The operator terms are summed in four lanes, operator j into lane
    // j % 4, then y = p0 f + ((l0 + l1) + (l2 + l3)): a fixed order, so the
    // same bits on every platform, but a dependency chain of ~N/4 additions
    // instead of N (the simulated stage's PI model is on the closed loop's
    // critical path), and four independent lanes a host compiler can run as
    // one vector. On a Cortex-M it costs at most four more additions.
    template <int N>
    static float apply_n(PiOperator& p, float x) {
        const PiModel& m = p.model_;
        // The plain model (Janaideh2016) plays x itself: no multiply and add
        // on the simulated loop's dependency chain for the stage's model.
        const float f = p.identity_input_ ? x : m.input_gain * dead_zone_map(m, x) + m.input_offset;
        float lane[4] = {0.0f, 0.0f, 0.0f, 0.0f};
        int j0 = 0;
#if PIEZOLOOP_FPV5
        float* g = p.groups_[0].r.data();
        [&]<std::size_t... G>(std::index_sequence<G...>) {
            (group_vldm<(N - 4 * static_cast<int>(G) < 4 ? N - 4 * static_cast<int>(G) : 4), G == 0>(g, f, lane),
             ...);
        }(std::make_index_sequence<(N + 3) / 4>{});
        j0 = N;
#elif PIEZOLOOP_PI_VECTOR_LANES
        // The same element-wise IEEE operations on the four lanes as one
        // 128-bit vector (GCC vector extension): the same bits as the scalar
        // loop below, a quarter of the instructions on the host.
        if constexpr (N >= 4) {
            using V = float __attribute__((vector_size(16)));
            const V fv = {f, f, f, f};
            V acc{};
            for (int g = 0; g + 4 <= N; g += 4) {
                Group& grp = p.groups_[static_cast<unsigned>(g / 4)];
                V r, w, wt;
                __builtin_memcpy(&r, grp.r.data(), sizeof(V));
                __builtin_memcpy(&w, grp.w.data(), sizeof(V));
                __builtin_memcpy(&wt, grp.p.data(), sizeof(V));
                const V hi = fv + r;
                const V mn = w < hi ? w : hi;  // min(u + r, w)
                const V lo = fv - r;
                const V nw = lo < mn ? mn : lo;  // max(u - r, .)
                __builtin_memcpy(grp.w.data(), &nw, sizeof(V));
                acc = g == 0 ? wt * nw : acc + wt * nw;
            }
            for (int k = 0; k < 4; ++k) lane[k] = acc[k];
            j0 = N / 4 * 4;
        }
#endif
#pragma GCC unroll 16
        for (int j = j0; j < N; ++j) {
            const unsigned i = static_cast<unsigned>(j);
            Group& grp = p.groups_[i / 4];
            const float w = play(f, grp.r[i % 4], grp.w[i % 4]);
            grp.w[i % 4] = w;
            const float term = grp.p[i % 4] * w;
            lane[j % 4] = j < 4 ? term : lane[j % 4] + term;
        }
        const float y0 = m.p0 * f;
        if constexpr (N >= 4) return y0 + ((lane[0] + lane[1]) + (lane[2] + lane[3]));
        else if constexpr (N == 3) return y0 + ((lane[0] + lane[1]) + lane[2]);
        else if constexpr (N == 2) return y0 + (lane[0] + lane[1]);
        else if constexpr (N == 1) return y0 + lane[0];
        else return y0;
    }
#if PIEZOLOOP_FPV5
    // K operators (1..4) of the group at g, operator k into lane k (the
    // group's first operator is 4i, and 4i % 4 = 0); First: the first group,
    // whose terms start the lanes. Thresholds and weights arrive in s16..s23
    // by one VLDM that steps g to the group's states, the states in s24..s27
    // by a second, and the new states leave from s24.. by a VSTM that steps
    // g to the next group: three instructions, no address arithmetic.
    // Registers of operators past K are loaded (the group's storage is
    // there) and unused.
    template <int K, bool First>
    [[gnu::always_inline]] static void group_vldm(float*& g, float f, float (&lane)[4]) {
        register float r0 asm("s16"), r1 asm("s17"), r2 asm("s18"), r3 asm("s19");
        register float p0 asm("s20"), p1 asm("s21"), p2 asm("s22"), p3 asm("s23");
        register float w0 asm("s24"), w1 asm("s25"), w2 asm("s26"), w3 asm("s27");
        asm("vldmia %[g]!, {s16-s23}\n\tvldmia %[g], {s24-s27}"
            : [g] "+r"(g), "=t"(r0), "=t"(r1), "=t"(r2), "=t"(r3), "=t"(p0), "=t"(p1), "=t"(p2), "=t"(p3),
              "=t"(w0), "=t"(w1), "=t"(w2), "=t"(w3)
            : "m"(*reinterpret_cast<const Group*>(g)));
        const float r[4] = {r0, r1, r2, r3}, w[4] = {w0, w1, w2, w3}, wt[4] = {p0, p1, p2, p3};
        float n[4] = {0.0f, 0.0f, 0.0f, 0.0f};
#pragma GCC unroll 4
        for (int k = 0; k < K; ++k) {
            n[k] = play(f, r[k], w[k]);
            const float term = wt[k] * n[k];
            lane[k] = First ? term : lane[k] + term;
        }
        // g points at this group's states: the memory operand names them.
        auto& states = *reinterpret_cast<std::array<float, 4>*>(g);
        register float n0 asm("s24") = n[0];
        if constexpr (K == 4) {
            register float n1 asm("s25") = n[1];
            register float n2 asm("s26") = n[2];
            register float n3 asm("s27") = n[3];
            asm("vstmia %[g]!, {s24-s27}" : [g] "+r"(g), "=m"(states) : "t"(n0), "t"(n1), "t"(n2), "t"(n3));
        } else if constexpr (K == 3) {
            register float n1 asm("s25") = n[1];
            register float n2 asm("s26") = n[2];
            asm("vstmia %[g], {s24-s26}" : "=m"(states) : [g] "r"(g), "t"(n0), "t"(n1), "t"(n2));
        } else if constexpr (K == 2) {
            register float n1 asm("s25") = n[1];
            asm("vstmia %[g], {s24-s25}" : "=m"(states) : [g] "r"(g), "t"(n0), "t"(n1));
        } else {
            asm("vstr s24, [%[g]]" : "=m"(states) : [g] "r"(g), "t"(n0));
        }
    }
#endif
    using ApplyFn = float (*)(PiOperator&, float);
    template <std::size_t... N>
    static constexpr std::array<ApplyFn, sizeof...(N)> apply_table(std::index_sequence<N...>) {
        return {&apply_n<static_cast<int>(N)>...};
    }

    PiModel model_{};
    bool identity_input_ = true;  // input_gain 1, input_offset 0, no dead zones: f = x
    std::array<Group, kMaxPlayOperators / 4> groups_{};
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
        // The input map's thresholds are Q31 samples of the input.
        for (int i = 0; i < m.dead_zones; ++i) {
            const double d = static_cast<double>(m.dead_zone_thresholds[static_cast<unsigned>(i)]) / in.full_scale;
            if (!(d > -1.0 && d < 1.0))
                return error("dead_zone_thresholds", i, "must be within the input's full scale in Q31");
        }
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
        identity_input_ = m.input_gain == 1.0f && m.input_offset == 0.0f && m.dead_zones == 0;
        // The input map, scaled by the input gain: input_gain * x and
        // input_gain * q_i with one block exponent; thresholds as Q31 samples,
        // so inside the input's full scale.
        zones_ = m.dead_zones;
        if (zones_ > 0) {
            std::array<double, kMaxDeadZones + 1> z{};
            z[0] = a;
            for (int i = 0; i < zones_; ++i) {
                const unsigned k = static_cast<unsigned>(i);
                zone_d_[k] = Q31::from_double(static_cast<double>(m.dead_zone_thresholds[k]) / in.full_scale).raw();
                z[k + 1] = a * static_cast<double>(m.dead_zone_weights[k]);
            }
            zone_exponent_ = block_exponent(z.data(), zones_ + 1);
            zone_gain_ = quantize_mantissa(z[0], zone_exponent_);
            for (int i = 0; i < zones_; ++i)
                zone_m_[static_cast<unsigned>(i)] = quantize_mantissa(z[static_cast<unsigned>(i) + 1], zone_exponent_);
        }
        reset();
        return ok_status();
    }
    void reset() { w_.fill(Q31{}); }
    // As the float operator's: w_j = t - r_j, saturated, in Q31 samples of
    // the play domain.
    void start_ascended_to(Q31 t) {
        for (int j = 0; j < count_; ++j) w_[static_cast<unsigned>(j)] = t - r_[static_cast<unsigned>(j)];
    }

    // Dispatches once on the operator count to a fully unrolled loop, as
    // the float operator does.
    Q31 apply(Q31 x);
    Q31 state(int j) const { return w_[static_cast<unsigned>(j)]; }

private:
    template <int N>
    static Q31 apply_n(PiOperator& p, Q31 x) {
        Q31 f = x;
        if (!p.identity_input_) {
            if (p.zones_ > 0) [[unlikely]] f = p.mapped_input(x) + p.input_offset_;
            else f = q31_from_accumulator(int64_t{p.input_gain_} * x.raw(), p.input_exponent_) + p.input_offset_;
        }
        int64_t acc = int64_t{p.p0_} * f.raw();
#pragma GCC unroll 16
        for (int j = 0; j < N; ++j) {
            const unsigned i = static_cast<unsigned>(j);
            const Q31 w = play(f, p.r_[i], p.w_[i]);
            p.w_[i] = w;
            acc += int64_t{p.p_[i]} * w.raw();
        }
        return q31_from_accumulator(acc, p.exponent_);
    }
    using ApplyFn = Q31 (*)(PiOperator&, Q31);
    template <std::size_t... N>
    static constexpr std::array<ApplyFn, sizeof...(N)> apply_table(std::index_sequence<N...>) {
        return {&apply_n<static_cast<int>(N)>...};
    }

    int count_ = 0;
    int exponent_ = 0;
    int32_t p0_ = 0;
    std::array<int32_t, kMaxPlayOperators> p_{};
    std::array<Q31, kMaxPlayOperators> r_{};
    std::array<Q31, kMaxPlayOperators> w_{};
    // input_gain * g(x), halved in the accumulator: |x - d_i| < 2^32 and
    // the mantissas' sum of magnitudes about 2^31, so the halved terms'
    // sum stays below 2^62 (one LSB of the input lost to the halving).
    Q31 mapped_input(Q31 x) const {
        int64_t acc = (int64_t{zone_gain_} * x.raw()) >> 1;
        for (int i = 0; i < zones_; ++i) {
            const unsigned k = static_cast<unsigned>(i);
            const int64_t e = int64_t{x.raw()} - zone_d_[k];
            if (e > 0) acc += int64_t{zone_m_[k]} * (e >> 1);
        }
        return q31_from_accumulator(acc, zone_exponent_ + 1);
    }

    bool identity_input_ = true;
    int input_exponent_ = 0;
    int32_t input_gain_ = 0;
    Q31 input_offset_{};
    int zones_ = 0;
    int zone_exponent_ = 0;
    int32_t zone_gain_ = 0;
    std::array<int32_t, kMaxDeadZones> zone_m_{};
    std::array<int32_t, kMaxDeadZones> zone_d_{};
};

// Defined after the classes: the dispatch tables need them complete.
inline float PiOperator<float>::apply(float x) {
    static constexpr std::array<ApplyFn, kMaxPlayOperators + 1> kApply =
        apply_table(std::make_index_sequence<kMaxPlayOperators + 1>{});
    return kApply[static_cast<unsigned>(model_.count)](*this, x);
}

inline Q31 PiOperator<Q31>::apply(Q31 x) {
    static constexpr std::array<ApplyFn, kMaxPlayOperators + 1> kApply =
        apply_table(std::make_index_sequence<kMaxPlayOperators + 1>{});
    return kApply[static_cast<unsigned>(count_)](*this, x);
}

}  // namespace piezoloop
