// Parallel PID on the error e with a filtered derivative, output limits and
// anti-windup (docs/models.md, 'Biquad cascades'; Shan2012's PI is the Kd = 0 case).
//
//   u = Kp e + Ki Ts sum_{k<=n} e[k] + D(z) e,   clamped to [u_min, u_max]
//
// Integral: backward Euler, I[n] = I[n-1] + Ki Ts e[n], so with Kd = 0 the
// controller is exactly Shan2012's Gc(z) = Kp + Ki Ts z / (z - 1).
//
// Derivative: Kd s / (1 + s tau), tau = 1 / (2 pi f_c), discretised
// step-invariantly (the pole maps to alpha = e^{-Ts/tau}; the step response
// equals the continuous one at the sample instants):
//   D(z) = (Kd / tau) (1 - z^-1) / (1 - alpha z^-1)
// realised through the low-passed error ef (unity DC gain, so its state is
// bounded by the error range rather than by the derivative gain):
//   delta = e[n] - ef[n-1],   d[n] = (Kd / tau) delta,   ef[n] = ef[n-1] + (1 - alpha) delta
// The first sample after a step of E is (Kd / tau) E, then it decays as alpha^n.
//
// Anti-windup by clamping (conditional integration): the integrator may move
// toward the limit only until the output reaches it, and never grows while
// the output is saturated in the same direction:
//   hi = max(I, u_max - p - d),  lo = min(I, u_min - p - d),  I = clamp(I + Ki Ts e, lo, hi)
// so when the error changes sign the output leaves saturation on that very
// sample (the integrator holds only what the output needed to reach the limit).
//
// Configuration apart from state: configure() validates everything and
// changes nothing when it rejects; on success the state carries on (the
// integrator is clamped into the new output range), reset() clears it.
#pragma once

#include <cstdint>
#include <type_traits>

#include "piezoloop/det_math.hpp"
#include "piezoloop/q31.hpp"
#include "piezoloop/sample.hpp"
#include "piezoloop/status.hpp"

namespace piezoloop {

struct PidConfig {
    float kp = 0.0f;                    // proportional gain, out per in (e.g. V/um)
    float ki_per_s = 0.0f;              // integral gain, out per (in * s)
    float kd_s = 0.0f;                  // derivative gain, out * s per in
    float derivative_cutoff_Hz = 0.0f;  // derivative low-pass cutoff, in (0, rate / 2)
    float u_min = 0.0f;                 // output limits (physical units of the output)
    float u_max = 0.0f;
    bool operator==(const PidConfig&) const = default;
};

namespace pid_detail {

inline constexpr double kTwoPi = 6.283185307179586476925;

// Coefficients in double, shared by both realisations (before sample scaling).
struct Coefficients {
    double kp = 0.0;     // Kp
    double ki_ts = 0.0;  // Ki Ts
    double kd_tau = 0.0; // Kd / tau = Kd 2 pi f_c
    double beta = 0.0;   // 1 - alpha, alpha = e^{-2 pi f_c Ts}
};

constexpr bool finite_nonnegative(float v) { return is_finite(v) && v >= 0.0f; }

constexpr Status validate(const PidConfig& c, float rate_Hz, SignalScale in, SignalScale out) {
    if (!is_finite(rate_Hz) || !(rate_Hz > 0.0f)) return error("sample_rate_Hz", "must be finite and > 0");
    // Reverse-acting loops negate the error (or a scale) upstream.
    if (!finite_nonnegative(c.kp)) return error("kp", "must be finite and >= 0");
    if (!finite_nonnegative(c.ki_per_s)) return error("ki_per_s", "must be finite and >= 0");
    if (!finite_nonnegative(c.kd_s)) return error("kd_s", "must be finite and >= 0");
    if (!is_finite(c.derivative_cutoff_Hz) || !(c.derivative_cutoff_Hz > 0.0f) ||
        !(static_cast<double>(c.derivative_cutoff_Hz) < 0.5 * static_cast<double>(rate_Hz)))
        return error("derivative_cutoff_Hz", "must be in (0, sample_rate_Hz / 2)");
    if (!is_finite(c.u_min)) return error("u_min", "must be finite");
    if (!is_finite(c.u_max) || !(c.u_min < c.u_max)) return error("u_max", "must be finite and > u_min");
    if (!is_finite(in.full_scale) || !(in.full_scale > 0.0f))
        return error("in.full_scale", "must be finite and > 0");
    if (!is_finite(out.full_scale) || !(out.full_scale > 0.0f))
        return error("out.full_scale", "must be finite and > 0");
    return ok_status();
}

constexpr Coefficients coefficients(const PidConfig& c, float rate_Hz) {
    const double ts = 1.0 / static_cast<double>(rate_Hz);
    const double x = kTwoPi * static_cast<double>(c.derivative_cutoff_Hz) * ts;  // Ts / tau, in (0, pi)
    Coefficients k;
    k.kp = c.kp;
    k.ki_ts = static_cast<double>(c.ki_per_s) * ts;
    k.kd_tau = static_cast<double>(c.kd_s) * kTwoPi * static_cast<double>(c.derivative_cutoff_Hz);
    k.beta = 1.0 - det_exp(-x);
    return k;
}

// Exponent e for a non-negative coefficient so that its mantissa is exact up
// to rounding and never saturates: c <= (2^31 - 1) 2^(e - 31). `copies` > 1
// reserves headroom for a mantissa that multiplies a 33-bit difference.
constexpr int coef_exponent(double c, int copies) {
    double l1[2] = {c, copies > 1 ? c : 0.0};
    int e = block_exponent(l1, 2);
    double top = 2147483647.0 / 2147483648.0;  // largest mantissa at exponent 0
    for (int i = 0; i < e; ++i) top *= 2.0;
    for (int i = 0; i > e; --i) top *= 0.5;
    if (copies > 1) top *= 0.5;
    return c > top ? e + 1 : e;
}

}  // namespace pid_detail

template <class T>
class Pid;

// ---------------------------------------------------------------------------
// float: physical units; the SignalScales are validated but unused.
template <>
class Pid<float> {
public:
    constexpr Status configure(const PidConfig& c, float sample_rate_Hz, SignalScale in, SignalScale out) {
        if (const Status s = pid_detail::validate(c, sample_rate_Hz, in, out); !s.ok()) return s;
        const pid_detail::Coefficients k = pid_detail::coefficients(c, sample_rate_Hz);
        kp_ = static_cast<float>(k.kp);
        ki_ts_ = static_cast<float>(k.ki_ts);
        kd_tau_ = static_cast<float>(k.kd_tau);
        beta_ = static_cast<float>(k.beta);
        u_min_ = c.u_min;
        u_max_ = c.u_max;
        integrator_ = min(max(integrator_, u_min_), u_max_);
        return ok_status();
    }

    constexpr float apply(float e) {
        const float p = kp_ * e;
        const float delta = e - filtered_;
        filtered_ = filtered_ + beta_ * delta;
        // A PI controller (kd = 0) skips the derivative's multiply and add:
        // they sit on the closed loop's dependency chain in simulation.
        const float pd = kd_tau_ == 0.0f ? p : p + kd_tau_ * delta;
        const float hi = max(integrator_, u_max_ - pd);
        const float lo = min(integrator_, u_min_ - pd);
        integrator_ = min(max(integrator_ + ki_ts_ * e, lo), hi);
        const float u = pd + integrator_;
        saturation_ = u >= u_max_ ? 1 : u <= u_min_ ? -1 : 0;
        return min(max(u, u_min_), u_max_);
    }

    constexpr void reset() {
        integrator_ = 0.0f;
        filtered_ = 0.0f;
        saturation_ = 0;
    }
    // +1 / -1 while the last output was at (or beyond) u_max / u_min, else 0.
    constexpr int saturation() const { return saturation_; }
    constexpr bool saturated() const { return saturation_ != 0; }
    // Integral term, physical output units (for telemetry and bumpless hand-over).
    constexpr float integrator() const { return integrator_; }

private:
    float kp_ = 0.0f, ki_ts_ = 0.0f, kd_tau_ = 0.0f, beta_ = 0.0f;
    float u_min_ = 0.0f, u_max_ = 0.0f;
    float integrator_ = 0.0f;
    float filtered_ = 0.0f;  // ef, the low-passed error
    int saturation_ = 0;
};

// ---------------------------------------------------------------------------
// Q31: error and output are Q31 samples (physical / full scale); gains are
// folded with in.full_scale / out.full_scale into block-exponent mantissas.
//
// Formats:
//   e, output, ef (low-passed error): Q31 int32
//   p, d, I, limits, sums: int64 Q55 (Q31 with kGuardBits = 24 more fraction
//     bits; the integrator resolves 2^-55 of full scale per sample, so even
//     Ki Ts ~ 1e-9 integrates small errors without stalling)
//   kp, Ki Ts: mantissa m, exponent e (c = m 2^(e-31)), product m * e_q31 is
//     value * 2^(62 - e), shifted right by 7 - e into Q55 (e <= 7)
//   Kd / tau, 1 - alpha: mantissas <= 2^30 (one exponent of headroom) since
//     they multiply delta = e - ef, a 33-bit difference: |m delta| <= 2^62
//   ef update: floor shift with first-order error feedback of the dropped
//     bits, so ef tracks e exactly on average however small 1 - alpha is.
// Ranges (why configure limits the sample-unit gains): |p| <= 64 (kp <= 64),
// |d| <= 64 (Kd / tau <= 32, |delta| <= 2), |I| <= 64 (clamped), so every sum
// stays below 256 = 2^63 in Q55.
// Cost: ~170 Thumb-2 instructions on a Cortex-M3 (four variable 64-bit
// shifts and the 64-bit clamps dominate); the float version is ~55 on a M7.
template <>
class Pid<Q31> {
public:
    static constexpr int kGuardBits = 24;
    static constexpr double kMaxGain = 64.0;            // kp, Ki Ts in sample units
    static constexpr double kMaxDerivativeGain = 32.0;  // Kd / tau in sample units

    constexpr Status configure(const PidConfig& c, float sample_rate_Hz, SignalScale in, SignalScale out) {
        if (const Status s = pid_detail::validate(c, sample_rate_Hz, in, out); !s.ok()) return s;
        const pid_detail::Coefficients k = pid_detail::coefficients(c, sample_rate_Hz);
        const double kp = SignalScale::sample_gain<Q31>(k.kp, in, out);
        const double ki_ts = SignalScale::sample_gain<Q31>(k.ki_ts, in, out);
        const double kd_tau = SignalScale::sample_gain<Q31>(k.kd_tau, in, out);
        if (!(kp <= kMaxGain)) return error("kp", "kp * in.full_scale / out.full_scale must be <= 64 for Q31");
        if (!(ki_ts <= kMaxGain))
            return error("ki_per_s", "ki_per_s / sample_rate_Hz * in/out full scale must be <= 64 for Q31");
        if (!(kd_tau <= kMaxDerivativeGain))
            return error("kd_s", "kd_s * 2 pi derivative_cutoff_Hz * in/out full scale must be <= 32 for Q31");
        const double fs = out.full_scale;
        if (!(c.u_min >= -fs)) return error("u_min", "must be >= -out.full_scale for Q31");
        if (!(c.u_max <= fs)) return error("u_max", "must be <= out.full_scale for Q31");
        const int64_t u_min = wide(Q31::from_double(c.u_min / fs).raw());
        const int64_t u_max = wide(Q31::from_double(c.u_max / fs).raw());
        if (!(u_min < u_max)) return error("u_max", "must exceed u_min by at least one Q31 LSB");

        const int ep = pid_detail::coef_exponent(kp, 1);
        const int ei = pid_detail::coef_exponent(ki_ts, 1);
        const int ed = pid_detail::coef_exponent(kd_tau, 2);
        const int eb = pid_detail::coef_exponent(k.beta, 2);
        kp_ = quantize_mantissa(kp, ep);
        ki_ts_ = quantize_mantissa(ki_ts, ei);
        kd_tau_ = quantize_mantissa(kd_tau, ed);
        beta_ = quantize_mantissa(k.beta, eb);
        kp_shift_ = 31 - kGuardBits - ep;
        ki_shift_ = 31 - kGuardBits - ei;
        kd_shift_ = 31 - kGuardBits - ed;
        // The residual is in units of the old shift; it is below one LSB of
        // ef either way, so dropping it on a change is harmless.
        if (31 - eb != beta_shift_) filtered_residual_ = 0;
        beta_shift_ = 31 - eb;
        u_min_ = u_min;
        u_max_ = u_max;
        integrator_ = integrator_ < u_min_ ? u_min_ : integrator_ > u_max_ ? u_max_ : integrator_;
        return ok_status();
    }

    constexpr Q31 apply(Q31 e_in) {
        const int64_t e = e_in.raw();
        const int64_t delta = e - filtered_;
        const int64_t p = (int64_t{kp_} * e) >> kp_shift_;
        const int64_t d = (int64_t{kd_tau_} * delta) >> kd_shift_;
        const int64_t step = (int64_t{ki_ts_} * e) >> ki_shift_;

        const int64_t f = int64_t{beta_} * delta + filtered_residual_;
        const int64_t f_step = f >> beta_shift_;
        filtered_residual_ = f - f_step * (int64_t{1} << beta_shift_);
        const int64_t ef = filtered_ + f_step;
        filtered_ = static_cast<int32_t>(ef > Q31::kMaxRaw ? Q31::kMaxRaw : ef < Q31::kMinRaw ? Q31::kMinRaw : ef);

        const int64_t pd = p + d;
        const int64_t hi = max64(integrator_, u_max_ - pd);
        const int64_t lo = min64(integrator_, u_min_ - pd);
        int64_t i = min64(max64(integrator_ + step, lo), hi);
        i = min64(max64(i, -kIntegratorLimit), kIntegratorLimit);
        integrator_ = i;

        int64_t u = pd + i;
        saturation_ = u >= u_max_ ? 1 : u <= u_min_ ? -1 : 0;
        u = min64(max64(u, u_min_), u_max_);
        return Q31::from_raw(static_cast<int32_t>((u + (int64_t{1} << (kGuardBits - 1))) >> kGuardBits));
    }

    constexpr void reset() {
        integrator_ = 0;
        filtered_ = 0;
        filtered_residual_ = 0;
        saturation_ = 0;
    }
    constexpr int saturation() const { return saturation_; }
    constexpr bool saturated() const { return saturation_ != 0; }
    // Integral term as a Q31 sample of the output scale (saturating).
    constexpr Q31 integrator() const {
        return Q31::saturate((integrator_ + (int64_t{1} << (kGuardBits - 1))) >> kGuardBits);
    }

private:
    static constexpr int64_t kIntegratorLimit = int64_t{64} << (31 + kGuardBits);
    static constexpr int64_t wide(int32_t q31) { return int64_t{q31} * (int64_t{1} << kGuardBits); }
    static constexpr int64_t max64(int64_t a, int64_t b) { return a < b ? b : a; }
    static constexpr int64_t min64(int64_t a, int64_t b) { return b < a ? b : a; }

    int32_t kp_ = 0, ki_ts_ = 0, kd_tau_ = 0, beta_ = 0;
    int kp_shift_ = 0, ki_shift_ = 0, kd_shift_ = 0, beta_shift_ = 31;
    int64_t u_min_ = 0, u_max_ = 0;
    int64_t integrator_ = 0;         // Q55
    int32_t filtered_ = 0;           // ef, Q31
    int64_t filtered_residual_ = 0;  // bits of the ef update below its LSB, [0, 2^beta_shift)
    int saturation_ = 0;
};

}  // namespace piezoloop
