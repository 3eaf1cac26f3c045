// Cascade of second-order sections (docs/models.md, 'Biquad cascades'), the realisation of every linear
// block of the core: feedback controllers, notch/low-pass filters, the RC Q
// filter, simulated plants.
//
// Per section (a0 = 1):   y = b0 x + b1 x1 + b2 x2 - a1 y1 - a2 y2
//
// Sections are designed on the host in double (SosSection) and realised here
// in one of two ways:
//
//  * float: direct form II transposed where float32 holds the section,
//    otherwise the section written in the delta operator d = z - 1 (its
//    denominator as offsets 2 + a1 and 1 + a1 + a2 from a double pole at
//    z = 1, computed in double) with compensated state updates, which holds
//    poles and zeros at |z| ~ 0.99997 as well as any other.
//
//  * Q31: direct form I, 64-bit accumulation, with the feedback written as an
//    offset from a double pole at z = 1 plus second-order error feedback, so
//    that poles at |z| ~ 0.99997 keep their low-frequency gain (formats below).
//
// Configuration is kept apart from state: configure() validates everything
// first and changes nothing when it rejects; apply() never fails.
#pragma once

#include <array>
#include <cstddef>
#include <cstdint>
#include <type_traits>

#include "piezoloop/det_math.hpp"
#include "piezoloop/fpv5.hpp"
#include "piezoloop/q31.hpp"
#include "piezoloop/sample.hpp"
#include "piezoloop/status.hpp"

namespace piezoloop {

// One section, designed on the host in double. a0 = 1.
struct SosSection {
    double b0 = 1.0, b1 = 0.0, b2 = 0.0;  // numerator
    double a1 = 0.0, a2 = 0.0;            // denominator (a0 = 1)
    bool operator==(const SosSection&) const = default;
};

template <class T, int MaxSections>
class BiquadCascade;

namespace detail {

// Field names "<prefix>[<i>].<coef>" as static strings: a Status must point
// at storage that outlives the call and the core cannot format at run time.
// The cascade names its coefficients "sections[i].b0"; a block that holds
// sections under another name (the pipeline's pre-filter: "prefilter[i].b0")
// renames with its own table. Only the tables in use are emitted.
inline constexpr int kSosFieldLength = 24;
inline constexpr const char* kSosCoefNames[5] = {"b0", "b1", "b2", "a1", "a2"};
inline constexpr char kSectionsName[] = "sections";

constexpr int text_length(const char* t) {
    int n = 0;
    while (t[n] != '\0') ++n;
    return n;
}
constexpr bool same_text(const char* a, const char* b) {
    if (a == nullptr || b == nullptr) return a == b;
    int i = 0;
    while (a[i] != '\0' && a[i] == b[i]) ++i;
    return a[i] == b[i];
}

template <int N, const char* Prefix>
struct SosFieldNames {
    static_assert(text_length(Prefix) + 9 < kSosFieldLength, "prefix too long for the field names");
    std::array<std::array<char, kSosFieldLength>, static_cast<std::size_t>(N) * 5> names{};

    constexpr SosFieldNames() {
        for (int i = 0; i < N; ++i) {
            for (int f = 0; f < 5; ++f) {
                auto& s = names[static_cast<std::size_t>(i * 5 + f)];
                int n = 0;
                for (const char* p = Prefix; *p != '\0'; ++p) s[static_cast<std::size_t>(n++)] = *p;
                s[static_cast<std::size_t>(n++)] = '[';
                char digits[4] = {};
                int d = 0;
                int v = i;
                do {
                    digits[d++] = static_cast<char>('0' + v % 10);
                    v /= 10;
                } while (v > 0);
                while (d > 0) s[static_cast<std::size_t>(n++)] = digits[--d];
                s[static_cast<std::size_t>(n++)] = ']';
                s[static_cast<std::size_t>(n++)] = '.';
                s[static_cast<std::size_t>(n++)] = kSosCoefNames[f][0];
                s[static_cast<std::size_t>(n++)] = kSosCoefNames[f][1];
                s[static_cast<std::size_t>(n)] = '\0';
            }
        }
    }
};

template <int N, const char* Prefix>
inline constexpr SosFieldNames<N, Prefix> kSosFieldNames{};

enum SosCoef : int { kB0 = 0, kB1 = 1, kB2 = 2, kA1 = 3, kA2 = 4 };

template <int N, const char* Prefix = kSectionsName>
constexpr const char* sos_field(int section, SosCoef coef) {
    return kSosFieldNames<N, Prefix>.names[static_cast<std::size_t>(section * 5 + coef)].data();
}

// A cascade's error on one of its coefficients ("sections[i].b0"), renamed
// "<Prefix>[i].b0" with no group; any other error unchanged.
template <int N, const char* Prefix>
constexpr Status renamed_sos_error(Status s) {
    for (int i = 0; i < N; ++i)
        for (int c = 0; c < 5; ++c)
            if (same_text(s.field, sos_field<N>(i, SosCoef(c))))
                return error(sos_field<N, Prefix>(i, SosCoef(c)), s.message);
    return s;
}

// Block exponent for coefficients quantised through their partial sums.
// block_exponent() gives sum|c| <= 2^e, so a coefficient (or partial sum)
// equal to +2^e would saturate to 2^31 - 1 and lose an LSB; one more exponent
// keeps gains like 1, 0.5 or 4 exact.
constexpr int partial_sum_exponent(const double* c, int n) {
    int e = block_exponent(c, n);
    if (e >= 31) return e;
    double largest = 0.0;  // most positive partial sum
    double sum = 0.0;
    for (int i = 0; i < n; ++i) {
        sum += c[i];
        largest = sum > largest ? sum : largest;
    }
    double top = 2147483647.0;  // largest mantissa, times 2^(e - 31)
    for (int i = 0; i < e; ++i) top *= 2.0;
    for (int i = 0; i > e; --i) top *= 0.5;
    top /= 2147483648.0;
    return largest > top ? e + 1 : e;
}

// Checks shared by both realisations. Poles strictly inside the unit circle
// is the stability triangle |a2| < 1, |a1| < 1 + a2.
template <int MaxSections>
constexpr Status validate_sos(const SosSection* sections, int count, SignalScale in, SignalScale out) {
    static_assert(MaxSections >= 1 && MaxSections <= 999, "MaxSections must be in [1, 999]");
    if (count < 1 || count > MaxSections) return error("count", "must be in [1, MaxSections]");
    if (sections == nullptr) return error("sections", "must not be null");
    if (!is_finite(in.full_scale) || !(in.full_scale > 0.0f))
        return error("in.full_scale", "must be finite and > 0");
    if (!is_finite(out.full_scale) || !(out.full_scale > 0.0f))
        return error("out.full_scale", "must be finite and > 0");
    for (int i = 0; i < count; ++i) {
        const SosSection& s = sections[i];
        const double c[5] = {s.b0, s.b1, s.b2, s.a1, s.a2};
        for (int f = 0; f < 5; ++f)
            if (!is_finite(c[f])) return error(sos_field<MaxSections>(i, SosCoef(f)), "must be finite");
        if (!(s.a2 < 1.0 && s.a2 > -1.0))
            return error(sos_field<MaxSections>(i, kA2), "poles must be inside the unit circle: |a2| < 1");
        const double a1_abs = s.a1 < 0.0 ? -s.a1 : s.a1;
        if (!(a1_abs < 1.0 + s.a2))
            return error(sos_field<MaxSections>(i, kA1), "poles must be inside the unit circle: |a1| < 1 + a2");
    }
    return ok_status();
}

}  // namespace detail

// ---------------------------------------------------------------------------
// float: per section, direct form II transposed where float32 holds it, the
// delta-operator form with compensated states where it does not.
//
// DF2T (y = b0 x + s1, s1 = b1 x - a1 y + s2, s2 = b2 x - a2 y) stores a1,
// a2 in float (~2^-24 of 2), but poles near z = 1 are set by c1 = 2 + a1,
// c0 = 1 + a1 + a2 (Ahmad2020 K(s) at 100 kHz: c0 ~ 1e-9), zeros by
// n1 = 2 b0 + b1, n0 = b0 + b1 + b2: lost (K(s) 29 dB off at 0.1 Hz).
//
// The delta-operator form writes the section in d = z - 1 (Middleton &
// Goodwin, "Improved finite word length characteristics in digital control
// using delta operators", IEEE TAC 31(11), 1986; the transposed direct form
// of Kauraniemi, Laakso, Hartimo & Ovaska, "Delta operator realizations of
// direct-form IIR filters", IEEE TCAS-II 45(1), 1998). With a0 = 1:
//
//   z^2 + a1 z + a2     = d^2 + c1 d + c0
//   b0 z^2 + b1 z + b2  = b0 d^2 + n1 d + n0
//   H = b0 + (g1 d + g0) / (d^2 + c1 d + c0),  g1 = n1 - b0 c1, g0 = n0 - b0 c0
//
//   y   = b0 x + s1
//   s1 += s2 + g1 x - c1 s1              (d s1 = -c1 s1 + s2 + g1 x)
//   s2 += g0 x - c0 s1                   (d s2 = -c0 s1 + g0 x)
//
// c1, c0, g1, g0 are computed in double from the double design at configure
// time and only then rounded to float: each keeps 24 significant bits however
// small it is, so poles and zeros move by ~2^-24 of their distance to z = 1.
// The states are integrators whose increments are small beside them near
// z = 1; plain float addition would drop the increments' low bits every
// sample (a deadband, and noise amplified by 1 / c0). Each state therefore
// carries the rounding residual of its last update into the next increment:
// compensated summation (Kahan, "Further remarks on reducing truncation
// errors", CACM 8(1), 1965; the residual is Dekker's Fast2Sum, 1971), i.e.
// first-order error feedback on the state (Higgins & Munson, "Noise
// reduction strategies for digital filters: error spectrum shaping versus
// the optimal linear state-space formulation", IEEE TASSP 30(6), 1982).
// Cost: 5 multiplies and 12 adds per section against DF2T's 5 and 4.
// The choice (configure, from the double coefficients), by FormChoice:
//  * kLowNoise (default: controllers and filters, whose later sections may
//    be near-integrators with gains of 1e9 that amplify any noise before
//    them): DF2T when rounding b0, b1, b2, a1, a2 to float changes none of
//    c1, c0, n1, n0, nor the sums at z = -1 (1 - a1 + a2, b0 - b1 + b2), by
//    more than 2^-20 of itself (response within ~1e-5 dB times the
//    section's resonance Q), and c0 = |1 - p|^2 >= 1/16: DF2T's state
//    rounding reaches the output through 1 / A(z), whose gain at z = 1 is
//    1 / c0; the delta form's compensated states do not see it.
//  * kCoefficients (models of physical plants, whose output noise is the
//    sensor's): DF2T when those changes are at most 2^-12 (response within
//    ~2e-3 dB times Q); the noise of a lightly used DF2T is far below any
//    sensor's.
// The delta form otherwise: well-conditioned sections keep DF2T and its
// cost, near-integrators and low-frequency notches get the delta form.
// form(i) reports the choice.
//
// Only float adds, subtracts and multiplies in a fixed order (built with
// -ffp-contract=off): host and boards agree bit for bit. Signals are
// physical values (SignalScale::sample_gain<float> is the identity).
enum class SectionForm : uint8_t { kDf2t, kDelta };
enum class FormChoice : uint8_t { kLowNoise, kCoefficients };

template <int MaxSections>
class BiquadCascade<float, MaxSections> {
public:
    static constexpr int kMaxSections = MaxSections;
    static constexpr double kDf2tTolerance = 1.0 / 1048576.0;      // 2^-20, kLowNoise
    static constexpr double kDf2tMinC0 = 1.0 / 16.0;               // kLowNoise: noise gain 1 / c0 <= 16
    static constexpr double kDf2tPlantTolerance = 1.0 / 4096.0;    // 2^-12, kCoefficients

    // Accepts 1..MaxSections stable, finite sections. On error names the field
    // (e.g. "sections[2].a2") and leaves configuration and state untouched.
    // On success the state carries on if the section count is unchanged
    // (retuning a running filter), and is zeroed if it changed.
    constexpr Status configure(const SosSection* sections, int count, SignalScale in, SignalScale out,
                               FormChoice choice = FormChoice::kLowNoise) {
        if (const Status s = detail::validate_sos<MaxSections>(sections, count, in, out); !s.ok()) return s;
        const double gain = SignalScale::sample_gain<float>(1.0, in, out);
        std::array<Coef, MaxSections> c{};
        for (int i = 0; i < count; ++i) {
            const SosSection& s = sections[i];
            const double g = i == 0 ? gain : 1.0;
            const double b0 = s.b0 * g, b1 = s.b1 * g, b2 = s.b2 * g;
            Coef& k = c[static_cast<std::size_t>(i)];
            if (df2t_holds(b0, b1, b2, s.a1, s.a2, choice)) {
                k = Coef{static_cast<float>(b0), static_cast<float>(b1), static_cast<float>(b2),
                         static_cast<float>(s.a1), static_cast<float>(s.a2), SectionForm::kDf2t};
            } else {
                const double c1 = s.a1 + 2.0;
                const double c0 = c1 + (s.a2 - 1.0);  // 1 + a1 + a2, > 0 for a stable section
                const double g1 = (2.0 * b0 + b1) - b0 * c1;
                const double g0 = (b0 + b1 + b2) - b0 * c0;
                k = Coef{static_cast<float>(b0), static_cast<float>(g1), static_cast<float>(g0),
                         static_cast<float>(c1), static_cast<float>(c0), SectionForm::kDelta};
            }
            if (!is_finite(k.k0) || !is_finite(k.k1) || !is_finite(k.k2))
                return error(detail::sos_field<MaxSections>(i, detail::kB0),
                             "numerator (first section: times in/out full scale) overflows float");
            // Realised poles strictly inside the unit circle, in c1, c0: c0 > 0,
            // c1 > c0 (a2 < 1), c0 - c1 + 2 > 0, 4 - 2 c1 + c0 > 0. A delta c0
            // below float's normal range is refused (FPUs differ on denormals).
            const bool delta = k.form == SectionForm::kDelta;
            const double q1 = delta ? double{k.k3} : double{k.k3} + 2.0;
            const double q0 = delta ? double{k.k4} : q1 + (double{k.k4} - 1.0);
            constexpr double kFloatMinNormal = 1.17549435082228750797e-38;  // 2^-126
            if (!(q0 > 0.0) || (delta && !(q0 >= kFloatMinNormal)) || !(4.0 - 2.0 * q1 + q0 > 0.0))
                return error(detail::sos_field<MaxSections>(i, detail::kA1),
                             "poles too close to the unit circle to be represented in float");
            if (!(q1 - q0 > 0.0) || !(q0 - q1 + 2.0 > 0.0))
                return error(detail::sos_field<MaxSections>(i, detail::kA2),
                             "poles too close to the unit circle to be represented in float");
        }
        coef_ = c;
        for (int i = 0; i < count; ++i) settle_gain_[static_cast<std::size_t>(i)] = settle_gain(c[static_cast<std::size_t>(i)]);
        if (count != count_) state_ = {};
        count_ = count;
        return ok_status();
    }

    // One sample through all sections. Unconfigured (count() == 0) it passes
    // the input through. Dispatches once on the section count to a loop of
    // known length, which the compiler unrolls (the tick's instruction budget
    // on the Cortex-M7); the arithmetic and its order are the same.
    constexpr float apply(float x) {
        // One jump table instead of a compare per possible count.
        switch (count_) {
            case 1: return apply_n<1>(x);
            case 2: return apply_n<2>(x);
            case 3: return apply_n<3>(x);
            case 4: return apply_n<4>(x);
            case 5: return apply_n<5>(x);
            case 6: return apply_n<6>(x);
            default: return apply_sections<7>(x);
        }
    }

    constexpr void reset() { state_ = {}; }

    // The state a constant input x settles to (its DC steady state): from
    // here, x in gives H(1) x out at once, up to float rounding, and the
    // state stays put. Per section, for its input x and output y = G x:
    //   DF2T:  s2 = b2 x - a2 y,  s1 = b1 x - a1 y + s2 (the updates of
    //          apply_n at rest; G = (b0 + b1 + b2) / (1 + a1 + a2));
    //   delta: both increments zero, s1 = (g0 / c0) x, s2 = c1 s1 - g1 x,
    //          residuals zero (G = b0 + g0 / c0).
    // The next section's input is what this one then outputs, b0 x + s1.
    // x = 0 is reset() exactly (no signed zeros). For a start from a given
    // point, not per sample: one multiply per section more than apply.
    constexpr void settle(float x) {
        if (x == 0.0f) {
            reset();
            return;
        }
        for (int i = 0; i < count_; ++i) {
            const Coef& c = coef_[static_cast<std::size_t>(i)];
            State& s = state_[static_cast<std::size_t>(i)];
            const float g = settle_gain_[static_cast<std::size_t>(i)];
            if (c.form == SectionForm::kDf2t) {
                const float y = g * x;
                s.s2 = c.k2 * x - c.k4 * y;
                s.s1 = c.k1 * x - c.k3 * y + s.s2;
            } else {
                s.s1 = g * x;
                s.s2 = c.k3 * s.s1 - c.k1 * x;
            }
            s.r1 = 0.0f;
            s.r2 = 0.0f;
            x = c.k0 * x + s.s1;
        }
    }

    constexpr int count() const { return count_; }
    constexpr SectionForm form(int i) const { return coef_[static_cast<std::size_t>(i)].form; }

    // Whether DF2T holds a section (above); float(v) - v is exact in double.
    static constexpr bool df2t_holds(double b0, double b1, double b2, double a1, double a2,
                                     FormChoice choice = FormChoice::kLowNoise) {
        const double e_b0 = static_cast<double>(static_cast<float>(b0)) - b0;
        const double e_b1 = static_cast<double>(static_cast<float>(b1)) - b1;
        const double e_b2 = static_cast<double>(static_cast<float>(b2)) - b2;
        const double e_a1 = static_cast<double>(static_cast<float>(a1)) - a1;
        const double e_a2 = static_cast<double>(static_cast<float>(a2)) - a2;
        const double c1 = a1 + 2.0, c0 = c1 + (a2 - 1.0);
        const double n1 = 2.0 * b0 + b1, n0 = (b0 + b1) + b2;
        // ... and the same at z = -1 (1 - a1 + a2, b0 - b1 + b2).
        const bool low_noise = choice == FormChoice::kLowNoise;
        const double t = low_noise ? kDf2tTolerance : kDf2tPlantTolerance;
        return (!low_noise || c0 >= kDf2tMinC0) && within(e_a1, c1, t) && within(e_a1 + e_a2, c0, t) &&
               within(2.0 * e_b0 + e_b1, n1, t) && within((e_b0 + e_b1) + e_b2, n0, t) &&
               within(e_a2 - e_a1, (1.0 - a1) + a2, t) && within((e_b0 - e_b1) + e_b2, (b0 - b1) + b2, t);
    }

private:
    static constexpr bool within(double error, double of, double tolerance) {
        const double e = error < 0.0 ? -error : error;
        const double v = of < 0.0 ? -of : of;
        return e <= tolerance * v;
    }

    // N sections, unrolled (N <= MaxSections; a larger N is never called).
    template <int N>
    constexpr float apply_n(float x) {
        if constexpr (N > MaxSections) {
            return x;
        } else {
            Cursor at{coef_.data(), state_.data()};
#pragma GCC unroll 8
            for (int i = 0; i < N; ++i) {
                const SectionForm form = at.coef->form;
                // k0..k4, then s1, s2, r1, r2; `at` moves to the next section.
                float k[5], st[4];
                load_section(at, k, st);
                if (form == SectionForm::kDf2t) {
                    // k0..k4 = b0, b1, b2, a1, a2
                    const float y = k[0] * x + st[0];
                    const float s1 = k[1] * x - k[3] * y + st[1];
                    const float s2 = k[2] * x - k[4] * y;
                    store_states<2>(at, {s1, s2, st[2], st[3]});
                    x = y;
                } else {
                    // k0..k4 = b0, g1, g0, c1, c0; increments with the
                    // residual their state lost last time.
                    const float y = k[0] * x + st[0];
                    const float i1 = ((st[1] + k[1] * x) - k[3] * st[0]) + st[2];
                    const float i2 = (k[2] * x - k[4] * st[0]) + st[3];
                    const float t1 = st[0] + i1;
                    const float r1 = i1 - (t1 - st[0]);  // what the rounding of t1 dropped
                    const float t2 = st[1] + i2;
                    const float r2 = i2 - (t2 - st[1]);
                    store_states<4>(at, {t1, t2, r1, r2});
                    x = y;
                }
            }
            return x;
        }
    }

    // Counts above 6: a compare per count from N on.
    template <int N>
    constexpr float apply_sections(float x) {
        if constexpr (N > MaxSections) {
            return x;
        } else {
            if (count_ != N) return apply_sections<N + 1>(x);
            return apply_n<N>(x);
        }
    }

    struct Coef {
        float k0 = 0.0f, k1 = 0.0f, k2 = 0.0f, k3 = 0.0f, k4 = 0.0f;  // per form, see apply_n
        SectionForm form = SectionForm::kDf2t;
    };
    struct State {
        float s1 = 0.0f, s2 = 0.0f;  // DF2T or delta-form states
        float r1 = 0.0f, r2 = 0.0f;  // delta form: rounding residuals (error feedback)
    };

    // The section apply_n is at: its coefficients (read) and states
    // (written back).
    struct Cursor {
        const Coef* coef;
        State* state;
    };
    // A section's coefficients and states into registers (the coefficients'
    // cursor moves on), and its new states back (the states' cursor moves
    // on). On a Cortex-M7 with FPv5 one VLDM each for the coefficients
    // (with the form's word, unused: 24 bytes, so the cursor lands on the
    // next section) and the states, and one VSTM for the states (a DF2T
    // section writes its unused residuals back unchanged), instead of a
    // VLDR or VSTR per value and the address arithmetic: the values pass
    // through fixed registers s16..s25. Elsewhere, and in constant
    // evaluation, plain loads and stores. The arithmetic is apply_n's.
    [[gnu::always_inline]] static constexpr void load_section(Cursor& at, float (&k)[5], float (&st)[4]) {
#if PIEZOLOOP_FPV5
        static_assert(sizeof(Coef) == 6 * sizeof(float) && sizeof(State) == 4 * sizeof(float));
        if (!std::is_constant_evaluated()) {
            register float k0 asm("s16"), k1 asm("s17"), k2 asm("s18"), k3 asm("s19"), k4 asm("s20");
            register float form_word asm("s21");
            register float s1 asm("s22"), s2 asm("s23"), r1 asm("s24"), r2 asm("s25");
            asm("vldmia %[c]!, {s16-s21}\n\tvldmia %[s], {s22-s25}"
                : [c] "+r"(at.coef), "=t"(k0), "=t"(k1), "=t"(k2), "=t"(k3), "=t"(k4), "=t"(form_word),
                  "=t"(s1), "=t"(s2), "=t"(r1), "=t"(r2)
                : [s] "r"(at.state), "m"(*at.coef), "m"(*at.state));
            k[0] = k0, k[1] = k1, k[2] = k2, k[3] = k3, k[4] = k4;
            st[0] = s1, st[1] = s2, st[2] = r1, st[3] = r2;
            return;
        }
#endif
        const Coef& c = *at.coef++;
        const State& s = *at.state;
        k[0] = c.k0, k[1] = c.k1, k[2] = c.k2, k[3] = c.k3, k[4] = c.k4;
        st[0] = s.s1, st[1] = s.s2, st[2] = s.r1, st[3] = s.r2;
    }
    // s1, s2, r1, r2 (K = 2: the first two are new, the residuals as loaded).
    template <int K>
    [[gnu::always_inline]] static constexpr void store_states(Cursor& at, const std::array<float, 4>& v) {
#if PIEZOLOOP_FPV5
        if (!std::is_constant_evaluated()) {
            register float s1 asm("s22") = v[0];
            register float s2 asm("s23") = v[1];
            register float r1 asm("s24") = v[2];
            register float r2 asm("s25") = v[3];
            asm("vstmia %[s]!, {s22-s25}"
                : [s] "+r"(at.state), "=m"(*at.state)
                : "t"(s1), "t"(s2), "t"(r1), "t"(r2));
            return;
        }
#endif
        State& s = *at.state++;
        s.s1 = v[0];
        s.s2 = v[1];
        if constexpr (K == 4) {
            s.r1 = v[2];
            s.r2 = v[3];
        }
    }

    // settle()'s gain per section, from the realised (float) coefficients
    // in double: DF2T G = (b0 + b1 + b2) / (1 + a1 + a2), delta g0 / c0.
    static constexpr float settle_gain(const Coef& c) {
        if (c.form == SectionForm::kDelta) return static_cast<float>(double{c.k2} / double{c.k4});
        const double num = (double{c.k0} + double{c.k1}) + double{c.k2};
        const double den = (1.0 + double{c.k3}) + double{c.k4};
        return static_cast<float>(num / den);
    }

    std::array<Coef, MaxSections> coef_{};
    std::array<State, MaxSections> state_{};
    int count_ = 0;
    // settle()'s gains, computed at configure so that the tick that starts an
    // approach pays no division; never read by apply.
    std::array<float, MaxSections> settle_gain_{};

public:
    // The states alone, for the feedback's anti-windup (anti_windup.hpp),
    // copied in place whole: a fixed-size copy is cheaper on the M7's FPU
    // registers than a loop over the sections in use.
    // On a Cortex-M7 with FPv5 four sections' states (16 words) are one
    // VLDM and one VSTM through s0..s15.
    using Snapshot = std::array<State, MaxSections>;
    constexpr void save(Snapshot& s) const {
#if PIEZOLOOP_FPV5
        if constexpr (sizeof(Snapshot) == 16 * sizeof(float)) {
            if (!std::is_constant_evaluated()) {
                asm("vldmia %[from], {s0-s15}\n\tvstmia %[to], {s0-s15}"
                    : "=m"(s)
                    : [from] "r"(state_.data()), [to] "r"(s.data()), "m"(state_)
                    : "s0", "s1", "s2", "s3", "s4", "s5", "s6", "s7", "s8", "s9", "s10", "s11", "s12", "s13", "s14",
                      "s15");
                return;
            }
        }
#endif
        s = state_;
    }
    constexpr void restore(const Snapshot& s) { state_ = s; }
};

// ---------------------------------------------------------------------------
// Q31: direct form I with the feedback taken relative to a double pole at z=1.
//
// Why: at 100 kHz a pole pair at |z| ~ 0.99997 (Ahmad2020 K(s)) has
// 1 + a1 + a2 ~ 1e-9, the quantity that sets the section's low-frequency
// gain. Plain Q31 a1/a2 with a coefficient shift of 1 resolve 2^-30 ~ 9e-10:
// the low-frequency gain would be off by ~100 %. Writing
//
//   c1 = a1 + 2,  c2 = a2 - 1      (both tiny for poles near z = 1)
//   y  = b0 x + b1 x1 + b2 x2 + (2 y1 - y2) - c1 y1 - c2 y2
//
// makes (2 y1 - y2) exact integer arithmetic and lets c1, c2 use their own
// block exponent: for the pole pair above |c1| + |c2| ~ 1.3e-4 -> exponent
// -12, so c1 + c2 = 1 + a1 + a2 is resolved to 2^-43 ~ 1e-13 (relative 1e-4).
// c2 is quantised so that c1 + c2 is the best-rounded value of 1 + a1 + a2,
// and b1, b2 so that the partial sums b0 + b1 and b0 + b1 + b2 (DC gain of
// the numerator) are best-rounded.
//
// Formats (Q31 sample: int32 x with value x / 2^31):
//   input, output, section histories x1, x2, y1, y2: Q31, saturating
//   numerator mantissas b0..b2:  b = m * 2^(eb - 31), sum|m| <= 2^31 (+1)
//   feedback mantissas c1, c2:   c = m * 2^(ec - 31), sum|m| <= 2^31 (+1)
//   accumulator: int64 Q59 (Q31 with kGuardBits = 28 extra fractional bits)
//     num = sum b_m * x   (int64, <= 2^62; value num * 2^(eb - 62))
//     fb  = sum c_m * y   (int64, <= 2^62; value fb * 2^(ec - 62))
//     acc = ((2 y1 - y2) << 28) + (2 e1 - e2) - (fb >> (3 - ec)) + (num >> (3 - eb))
//     y   = saturate(acc >> 28)  (floor),  e = acc - (y << 28) in [0, 2^28)
//   Since (y << 28) + e is the previous acc itself, the first two terms are
//   computed as 2 w1 - w2 from the two previous unrounded accumulators w1, w2
//   (the only extra state; on saturation w = y << 28, i.e. e = 0).
//   Range: |2 y1 - y2 - c1 y1 - c2 y2| = |a1 y1 + a2 y2| <= 3, |fb| <= 2^ec
//   <= 8 (|c1| < 4, |c2| < 2 for a stable section, so ec <= 3), |num| <= 2^eb,
//   so for eb <= 3 |acc| < 12 * 2^59 < 2^63.
//
// High-gain numerators (3 < eb <= kMaxNumeratorExponent): a controller with a
// large gain between error and command (Ahmad2020 K(s): ~500 between the
// samples of a 40 µm error and a 16 V command) needs sum|b| far above 8 in
// its last section. Then num is shifted LEFT by eb - 3 into Q59, after
// clamping it to +-8 (2^62 in Q59). The clamp changes nothing that matters:
// the other terms of acc are bounded by 3 in value, so |num| > 8 means
// |acc| > 5 and the output saturates, with num's sign, either way. No bits
// are lost (the products are exact and the shift is left); |acc| < 12 * 2^59
// still. Such a section saturates for inputs above 1 / (its gain) of full
// scale: the design decides whether that is acceptable (for a loop's error
// it is: a large error saturates the command in any realisation).
//
// Error feedback: the residual e dropped when rounding acc to the Q31 output
// re-enters the next accumulator as 2 e1 - e2, so the output is
// y = v - (1 - z^-1)^2 e: the truncation noise is shaped by a double zero at
// z = 1 and never sees the ~1e9 DC gain of 1 / A(z) near z = 1. What remains
// unshaped is the floor of the two product shifts, at 2^-59 of full scale
// each (a few Q31 LSB after a 1e9 DC gain).
//
// The physical gain in.full_scale / out.full_scale is folded into the first
// section's numerator: intermediate nodes are normalised by out.full_scale,
// so the host design must keep every partial cascade within +-out.full_scale
// for the inputs it expects (per-section scaling, docs/models.md, 'Biquad cascades').
//
// Cost per section: five 32x32->64 multiply-accumulates, two variable 64-bit
// shifts, the saturation test and the history moves (~75 Thumb-2
// instructions on a Cortex-M3 with GCC -O2; CMSIS-DSP's DF1 32x64 is ~120).
template <int MaxSections>
class BiquadCascade<Q31, MaxSections> {
public:
    static constexpr int kMaxSections = MaxSections;
    static constexpr int kGuardBits = 28;   // accumulator Q59 = Q31 + 28 bits
    static constexpr int kPlainNumeratorExponent = 3;  // sum|b| < 8: right shifts only
    static constexpr int kMaxNumeratorExponent = 24;   // sum|b| (sample units) < 2^24

    // Same contract as the float cascade, plus: the numerator of every section
    // (the first one times in.full_scale / out.full_scale) must have
    // sum|b| < 2^24, and the quantised poles must still be strictly inside the
    // unit circle.
    constexpr Status configure(const SosSection* sections, int count, SignalScale in, SignalScale out) {
        if (const Status s = detail::validate_sos<MaxSections>(sections, count, in, out); !s.ok()) return s;
        const double gain = SignalScale::sample_gain<Q31>(1.0, in, out);
        std::array<Coef, MaxSections> c{};
        for (int i = 0; i < count; ++i) {
            const SosSection& s = sections[i];
            const double g = i == 0 ? gain : 1.0;
            const double b[3] = {s.b0 * g, s.b1 * g, s.b2 * g};
            if (!is_finite(b[0]) || !is_finite(b[1]) || !is_finite(b[2]))
                return error(detail::sos_field<MaxSections>(i, detail::kB0),
                             "numerator times in/out full scale must be finite");
            const int eb = detail::partial_sum_exponent(b, 3);
            if (eb > kMaxNumeratorExponent)
                return error(detail::sos_field<MaxSections>(i, detail::kB0),
                             "sum |b| (first section: times in/out full scale) must be < 2^24 for Q31");
            // a1 + 2 and a2 - 1 are exact in double for poles near z = 1
            // (Sterbenz), and so is their sum up to one rounding.
            const double fb[2] = {s.a1 + 2.0, s.a2 - 1.0};
            const double fb_sum = fb[0] + fb[1];  // = 1 + a1 + a2 > 0 for a stable section
            const int ec = detail::partial_sum_exponent(fb, 2);

            Coef& k = c[static_cast<std::size_t>(i)];
            const int64_t m0 = quantize_mantissa(b[0], eb);
            const int64_t m01 = quantize_mantissa(b[0] + b[1], eb);
            const int64_t m012 = quantize_mantissa(b[0] + b[1] + b[2], eb);
            k.b0 = clamp_i32(m0);
            k.b1 = clamp_i32(m01 - m0);
            k.b2 = clamp_i32(m012 - m01);
            const int64_t n1 = quantize_mantissa(fb[0], ec);
            const int64_t n12 = quantize_mantissa(fb_sum, ec);
            k.c1 = clamp_i32(n1);
            k.c2 = clamp_i32(n12 - n1);
            const bool high_gain = eb > kPlainNumeratorExponent;
            k.num_shift = high_gain ? 0 : static_cast<uint8_t>(31 - kGuardBits - eb);  // 0 .. 34
            k.num_left = high_gain ? static_cast<uint8_t>(eb - kPlainNumeratorExponent) : 0;  // 0 .. 21
            k.fb_shift = static_cast<uint8_t>(31 - kGuardBits - ec);   // 0 .. 34

            // Stability of the quantised section, in mantissa units
            // (one = 2^(31 - ec)): 1 + a1 + a2 = c1 + c2 > 0, a2 = c2 + 1 < 1,
            // a2 > -1 <=> c2 > -2, 1 - a1 + a2 = 4 - c1 + c2 > 0. The last two
            // can only fail when ec > 0 (otherwise one >= 2^31 >= |c1|, |c2|).
            const int64_t q1 = k.c1, q2 = k.c2;
            const int64_t one = ec > 0 ? int64_t{1} << (31 - ec) : int64_t{1} << 31;
            if (!(q1 + q2 > 0) || !(4 * one - q1 + q2 > 0))
                return error(detail::sos_field<MaxSections>(i, detail::kA1),
                             "poles too close to the unit circle to be represented in Q31");
            if (!(q2 < 0) || !(q2 > -2 * one))
                return error(detail::sos_field<MaxSections>(i, detail::kA2),
                             "poles too close to the unit circle to be represented in Q31");
        }
        bool small = true;
        for (int i = 0; i < count; ++i) {
            const Coef& k = c[static_cast<std::size_t>(i)];
            small = small && k.num_shift < 32 && k.fb_shift < 32 && k.num_left == 0;
        }
        coef_ = c;
        for (int i = 0; i < count; ++i) settle_gain_[static_cast<std::size_t>(i)] = settle_gain(c[static_cast<std::size_t>(i)]);
        small_shifts_ = small;
        if (count != count_) {
            hist_ = {};
            wide_ = {};
        }
        count_ = count;
        return ok_status();
    }

    // One sample through all sections. Unconfigured (count() == 0) it passes
    // the input through. Dispatches once per sample on whether every product
    // shift is a right shift below 32 (the usual case: exponents down to
    // -28): then each 64-bit shift is a handful of 32-bit instructions on a
    // Cortex-M3 instead of the general sequence with its >= 32 branch and the
    // high-gain numerators' clamped left shift.
    constexpr Q31 apply(Q31 in) { return small_shifts_ ? apply_impl<true>(in) : apply_impl<false>(in); }

    constexpr void reset() {
        hist_ = {};
        wide_ = {};
    }

    // The state a constant input x settles to (its DC steady state), as the
    // float cascade's settle(): every history of a section's input holds
    // that input, every history of its output y = G x, and its unrounded
    // accumulators w1 = w2 = G x in Q59 (so 2 w1 - w2 = w: no error-feedback
    // kick). G is the quantised section's own DC gain, the x at which
    // the numerator's and the feedback's contributions to acc cancel:
    // G = sum(b) / (c1 + c2) * 2^(fb_shift - numerator shift), kept as a
    // Q31 mantissa and a shift (configure()). A y beyond Q31 saturates as in
    // apply(). x = 0 is reset() exactly. Integer arithmetic only.
    constexpr void settle(Q31 in) {
        int32_t x = in.raw();
        if (x == 0) {
            reset();
            return;
        }
        for (int i = 0; i < count_; ++i) {
            const std::size_t k = static_cast<std::size_t>(i);
            int64_t w = settled_q59(x, settle_gain_[k]);
            int64_t y = w >> kGuardBits;
            if (y > Q31::kMaxRaw) {
                y = Q31::kMaxRaw;
                w = y * (int64_t{1} << kGuardBits);
            } else if (y < Q31::kMinRaw) {
                y = Q31::kMinRaw;
                w = y * (int64_t{1} << kGuardBits);
            }
            hist_[k] = {x, x};
            wide_[k] = {w, w};
            x = static_cast<int32_t>(y);
        }
        hist_[static_cast<std::size_t>(count_)] = {x, x};
    }

    constexpr int count() const { return count_; }

private:
    // v >> s (arithmetic); with kSmall, s < 32 and the shift is written on
    // the two 32-bit halves (GCC's general 64-bit shift also handles s >= 32).
    template <bool kSmall>
    static constexpr int64_t shift_right(int64_t v, unsigned s) {
        if constexpr (kSmall) {
            const uint32_t lo = static_cast<uint32_t>(static_cast<uint64_t>(v));
            const int32_t hi = static_cast<int32_t>(v >> 32);
            // hi << (32 - s) as (hi << 1) << (31 - s): defined for s = 0 too.
            const uint32_t out_lo = (lo >> s) | ((static_cast<uint32_t>(hi) << 1) << (31u - s));
            const int32_t out_hi = hi >> s;
            return static_cast<int64_t>((static_cast<uint64_t>(static_cast<uint32_t>(out_hi)) << 32) | out_lo);
        } else {
            return v >> s;
        }
    }

    template <bool kSmall>
    constexpr Q31 apply_impl(Q31 in) {
        int32_t x = in.raw();
        for (int i = 0; i < count_; ++i) {
            const Coef& c = coef_[static_cast<std::size_t>(i)];
            // DF1 cascade sharing histories: hist_[i] is the past of section
            // i's input, hist_[i + 1] the past of its output (= next input).
            std::array<int32_t, 2>& xh = hist_[static_cast<std::size_t>(i)];
            const std::array<int32_t, 2>& yh = hist_[static_cast<std::size_t>(i) + 1];
            std::array<int64_t, 2>& w = wide_[static_cast<std::size_t>(i)];

            const int64_t num = int64_t{c.b0} * x + int64_t{c.b1} * xh[0] + int64_t{c.b2} * xh[1];
            const int64_t fb = int64_t{c.c1} * yh[0] + int64_t{c.c2} * yh[1];
            // 2 w1 - w2 = ((2 y1 - y2) << 28) + 2 e1 - e2: the exact double
            // pole at z = 1 and the error feedback in one step.
            int64_t acc = 2 * w[0] - w[1];
            acc -= shift_right<kSmall>(fb, c.fb_shift);
            acc += numerator_q59<kSmall>(num, c);

            int64_t y = acc >> kGuardBits;  // floor; the residual stays in acc
            if (y > Q31::kMaxRaw) {
                y = Q31::kMaxRaw;
                acc = y * (int64_t{1} << kGuardBits);  // residual zeroed
            } else if (y < Q31::kMinRaw) {
                y = Q31::kMinRaw;
                acc = y * (int64_t{1} << kGuardBits);
            }
            w[1] = w[0];
            w[0] = acc;
            xh[1] = xh[0];
            xh[0] = x;
            x = static_cast<int32_t>(y);
        }
        std::array<int32_t, 2>& last = hist_[static_cast<std::size_t>(count_)];
        last[1] = last[0];
        last[0] = x;
        return Q31::from_raw(x);
    }

    struct Coef {
        int32_t b0 = 0, b1 = 0, b2 = 0;  // numerator mantissas, exponent eb
        int32_t c1 = 0, c2 = 0;          // a1 + 2, a2 - 1 mantissas, exponent ec
        uint8_t num_shift = 0;           // 3 - eb: numerator products -> Q59 (eb <= 3)
        uint8_t num_left = 0;            // eb - 3: the same, shifted left (eb > 3)
        uint8_t fb_shift = 0;            // 3 - ec: feedback products -> Q59
    };

    // The numerator's contribution in Q59 (see "High-gain numerators").
    template <bool kSmall>
    static constexpr int64_t numerator_q59(int64_t num, const Coef& c) {
        if constexpr (!kSmall) {
            if (c.num_left > 0) {
                constexpr int64_t kEight = int64_t{1} << 62;  // 8 in Q59
                const int64_t limit = kEight >> c.num_left;
                if (num >= limit) return kEight;
                if (num <= -limit) return -kEight;
                return num * (int64_t{1} << c.num_left);
            }
        }
        return shift_right<kSmall>(num, c.num_shift);
    }
    static constexpr int32_t clamp_i32(int64_t v) {
        return v > Q31::kMaxRaw ? Q31::kMaxRaw : v < Q31::kMinRaw ? Q31::kMinRaw : static_cast<int32_t>(v);
    }

    // A section's DC gain G = m * 2^-shift, m a Q31 mantissa (|m| in
    // [2^30, 2^31), or 0 for G = 0).
    struct SettleGain {
        int32_t m = 0;
        int32_t shift = 0;
    };
    static constexpr SettleGain settle_gain(const Coef& c) {
        const int64_t b = int64_t{c.b0} + int64_t{c.b1} + int64_t{c.b2};
        const int64_t a = int64_t{c.c1} + int64_t{c.c2};  // > 0: configure() checked it
        const int numerator_shift = c.num_left > 0 ? -int{c.num_left} : int{c.num_shift};
        double g = static_cast<double>(b) / static_cast<double>(a);
        int shift = numerator_shift - int{c.fb_shift};  // g * 2^-shift is G
        if (g == 0.0) return {};
        const double mag_limit = 2147483648.0;  // 2^31
        // Normalise |g| into [2^30, 2^31) by powers of two (exact); a gain
        // beyond 2^-300 .. 2^300 never reaches here (|b| < 2^32, a >= 1).
        while ((g < 0.0 ? -g : g) < mag_limit / 2.0) {
            g *= 2.0;
            ++shift;
        }
        while ((g < 0.0 ? -g : g) >= mag_limit) {
            g *= 0.5;
            --shift;
        }
        int64_t m = static_cast<int64_t>(g < 0.0 ? g - 0.5 : g + 0.5);  // round half away
        if (m >= int64_t{1} << 31 || m <= -(int64_t{1} << 31)) {  // rounded up to 2^31
            m /= 2;
            --shift;
        }
        return {static_cast<int32_t>(m), static_cast<int32_t>(shift)};
    }
    // x G in Q59 (Q31 with kGuardBits more), saturated beyond +-2^60 (a y
    // that saturates either way).
    static constexpr int64_t settled_q59(int32_t x, SettleGain g) {
        const int64_t p = int64_t{x} * g.m;  // |p| < 2^62
        const int up = kGuardBits - g.shift;  // x G 2^28 = p 2^up
        constexpr int64_t kBeyond = int64_t{1} << 60;
        if (up >= 0) {
            if (p == 0) return 0;
            if (up >= 60) return p > 0 ? kBeyond : -kBeyond;
            const int64_t limit = kBeyond >> up;
            if (p >= limit) return kBeyond;
            if (p <= -limit) return -kBeyond;
            return p * (int64_t{1} << up);
        }
        if (-up >= 63) return p < 0 ? -1 : 0;
        return p >> -up;
    }

    std::array<Coef, MaxSections> coef_{};
    std::array<std::array<int32_t, 2>, MaxSections + 1> hist_{};  // {z^-1, z^-2} of each node
    std::array<std::array<int64_t, 2>, MaxSections> wide_{};  // unrounded outputs w1, w2, Q59
    int count_ = 0;
    bool small_shifts_ = true;  // every shift right and below 32 (no high-gain numerator)
    // settle()'s gains, computed at configure so that the tick that starts an
    // approach does no double arithmetic; never read by apply.
    std::array<SettleGain, MaxSections> settle_gain_{};

public:
    // The states alone, for the feedback's anti-windup (anti_windup.hpp):
    // only the sections in use, copied in place (it runs every tick).
    struct Snapshot {
        std::array<std::array<int32_t, 2>, MaxSections + 1> hist;
        std::array<std::array<int64_t, 2>, MaxSections> wide;
    };
    constexpr void save(Snapshot& s) const {
        for (int i = 0; i < count_; ++i) {
            s.hist[static_cast<std::size_t>(i)] = hist_[static_cast<std::size_t>(i)];
            s.wide[static_cast<std::size_t>(i)] = wide_[static_cast<std::size_t>(i)];
        }
        s.hist[static_cast<std::size_t>(count_)] = hist_[static_cast<std::size_t>(count_)];
    }
    constexpr void restore(const Snapshot& s) {
        for (int i = 0; i < count_; ++i) {
            hist_[static_cast<std::size_t>(i)] = s.hist[static_cast<std::size_t>(i)];
            wide_[static_cast<std::size_t>(i)] = s.wide[static_cast<std::size_t>(i)];
        }
        hist_[static_cast<std::size_t>(count_)] = s.hist[static_cast<std::size_t>(count_)];
    }
};

}  // namespace piezoloop
