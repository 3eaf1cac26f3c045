// Output protection of the piezo: the last block before the DAC.
//
//   u_out = hard_clamp( slew_limit( clamp(u, u_min, u_max) ) )
//
// Two layers of limits:
// - HardLimits are facts of the board (amplifier output range, what the piezo
//   stack survives, the largest slew its drive current allows). They are
//   constants of the firmware, given once at construction, and are applied
//   last and unconditionally: no runtime parameter set and no input (NaN,
//   ±Inf, denormals, 1e38) can produce an output outside [u_min_V, u_max_V]
//   of the hard limits or a step larger than slew_max_V_per_s / sample rate.
// - LimitsConfig is the runtime (user) setting, validated against the hard
//   limits; a rejected configuration leaves the previous one active.
//
// Ordering: the command is first clamped to the configured range, then the
// output moves towards it by at most one slew step per sample, then the hard
// clamp is applied. Clamping *before* slewing means a narrowed range is entered
// at the slew rate (never by a jump), so for a few samples after such a
// reconfiguration the output can lie outside the new configured range, but
// never outside the hard limits.
//
// Trips (latched, first cause kept, released only by clear_trip()):
// - a non-finite input (float only: NaN, ±Inf) — a NaN in the loop means some
//   upstream block is broken, and its next samples are not to be trusted;
// - sustained saturation (optional): the command was clamped to the configured
//   range for saturation_trip_s without a break. A loop that pins its output
//   for that long has lost the sensor or wound up; holding full voltage on the
//   stage is then the wrong thing to do;
// - external: trip(reason) from the pipeline (sensor fault, link watchdog).
// Safe output while tripped: the clamp of 0 V to the configured range,
// *reached at the slew rate*. A jump to 0 V from, say, 100 V is itself a
// hazard for a stacked piezo (the fast contraction puts the ceramic under
// tension and excites the stage resonance); holding the last output would keep
// the stage energised indefinitely. Ramping down at the configured slew gives
// neither. Before the first successful configure() the limiter behaves as
// tripped (reason kNotConfigured) and ramps to the clamp of 0 V to the hard
// range; the first accepted configuration releases that reason only.
//
// Float resolution: a float output near 120 V has a resolution (ulp) of
// 7.6e-6 V; a per-sample slew step below that would stall the output (adding
// it rounds back to the same value). configure() therefore rejects slews whose
// per-sample step is below 2 ulp of the largest hard limit (Q31: below 2 LSB).
// The float hard slew bound is made exact despite the rounding of last + step
// by using a per-sample step one ulp(range) below slew_max / rate.
#pragma once

#include <bit>
#include <cstdint>
#include <type_traits>

#include "piezoloop/det_math.hpp"
#include "piezoloop/q31.hpp"
#include "piezoloop/sample.hpp"
#include "piezoloop/status.hpp"

namespace piezoloop {

// Board constants: what the hardware can take. Never exceeded.
struct HardLimits {
    float u_min_V = 0.0f;
    float u_max_V = 0.0f;
    float slew_max_V_per_s = 0.0f;
};

// Runtime setting, must lie within the hard limits.
struct LimitsConfig {
    float u_min_V = 0.0f;
    float u_max_V = 0.0f;
    float slew_V_per_s = 0.0f;
    // 0 disables; otherwise trip when the command has been clamped to
    // [u_min_V, u_max_V] continuously for this long (rounded to the nearest
    // sample, at least one).
    float saturation_trip_s = 0.0f;
};

enum class TripReason : uint8_t {
    kNone = 0,
    kNotConfigured,      // no configuration accepted yet (cleared by configure)
    kInvalidHardLimits,  // construction failed: permanent, output is zero
    kNonFinite,          // NaN or ±Inf input (float)
    kSustainedSaturation,
    kExternal,           // trip() from outside
};

constexpr const char* trip_reason_name(TripReason r) {
    switch (r) {
        case TripReason::kNone: return "none";
        case TripReason::kNotConfigured: return "not configured";
        case TripReason::kInvalidHardLimits: return "invalid hard limits";
        case TripReason::kNonFinite: return "non-finite input";
        case TripReason::kSustainedSaturation: return "sustained saturation";
        case TripReason::kExternal: return "external";
    }
    return "?";
}

namespace limits_detail {

// Volts beyond this are not a piezo amplifier; also keeps every sum of two
// limits far from float overflow.
inline constexpr float kMaxAbsVolt = 1.0e6f;
inline constexpr float kMaxSlew_V_per_s = 1.0e12f;
inline constexpr float kMaxRate_Hz = 1.0e8f;
inline constexpr float kMaxTrip_s = 1.0e3f;

// Distance from |x| (finite) to the next larger float: the output resolution there.
constexpr float ulp(float x) {
    const float a = x < 0.0f ? -x : x;
    const float up = std::bit_cast<float>(std::bit_cast<uint32_t>(a) + 1u);
    return up - a;  // exact (Sterbenz)
}

// Largest float <= d, for 0 <= d < FLT_MAX.
constexpr float round_down_to_float(double d) {
    float f = static_cast<float>(d);
    if (static_cast<double>(f) > d && f > 0.0f) {
        f = std::bit_cast<float>(std::bit_cast<uint32_t>(f) - 1u);
    }
    return f;
}

// floor / ceil of a double without libm; the argument is clamped to
// +-2^62 first (callers clamp the result to the Q31 range anyway).
constexpr int64_t floor_i64(double x) {
    constexpr double kLim = 4611686018427387904.0;  // 2^62
    if (!(x > -kLim)) return -(int64_t{1} << 62);
    if (x > kLim) return int64_t{1} << 62;
    const int64_t t = static_cast<int64_t>(x);  // truncates toward zero
    return static_cast<double>(t) > x ? t - 1 : t;
}
constexpr int64_t ceil_i64(double x) { return -floor_i64(-x); }

constexpr uint32_t sat_inc(uint32_t c) { return c == 0xffffffffu ? c : c + 1u; }

// Q31 conversions of volts, rounded *inwards* by a margin that covers the
// rounding of the double division (< 2^-20 LSB for |q| <= 2^32), so the
// resulting raw value is inside the limit in exact arithmetic.
inline constexpr double kQ31Margin = 1.0 / 256.0;
constexpr int64_t q31_raw_at_or_above(double volts, double full_scale) {
    return ceil_i64(volts / full_scale * 2147483648.0 + kQ31Margin);
}
constexpr int64_t q31_raw_at_or_below(double volts, double full_scale) {
    return floor_i64(volts / full_scale * 2147483648.0 - kQ31Margin);
}

}  // namespace limits_detail

constexpr Status validate(const HardLimits& h) {
    using limits_detail::kMaxAbsVolt;
    if (!is_finite(h.u_min_V) || h.u_min_V < -kMaxAbsVolt || h.u_min_V > kMaxAbsVolt)
        return error("u_min_V", "hard limit must be finite and within +-1e6 V");
    if (!is_finite(h.u_max_V) || h.u_max_V < -kMaxAbsVolt || h.u_max_V > kMaxAbsVolt)
        return error("u_max_V", "hard limit must be finite and within +-1e6 V");
    if (!(h.u_min_V < h.u_max_V)) return error("u_max_V", "hard limit must be > u_min_V");
    if (!is_finite(h.slew_max_V_per_s) || !(h.slew_max_V_per_s > 0.0f) ||
        h.slew_max_V_per_s > limits_detail::kMaxSlew_V_per_s)
        return error("slew_max_V_per_s", "hard limit must be in (0, 1e12] V/s");
    return ok_status();
}

// A runtime setting against the board's hard limits.
constexpr Status validate(const LimitsConfig& c, const HardLimits& h) {
    if (const Status s = validate(h); !s.ok()) return s;
    if (!is_finite(c.u_min_V) || c.u_min_V < h.u_min_V)
        return error("u_min_V", "must be finite and >= the hard limit u_min_V");
    if (!is_finite(c.u_max_V) || c.u_max_V > h.u_max_V)
        return error("u_max_V", "must be finite and <= the hard limit u_max_V");
    if (!(c.u_min_V < c.u_max_V)) return error("u_max_V", "must be > u_min_V");
    if (!is_finite(c.slew_V_per_s) || !(c.slew_V_per_s > 0.0f) ||
        c.slew_V_per_s > h.slew_max_V_per_s)
        return error("slew_V_per_s", "must be in (0, hard slew_max_V_per_s]");
    if (!is_finite(c.saturation_trip_s) || c.saturation_trip_s < 0.0f ||
        c.saturation_trip_s > limits_detail::kMaxTrip_s)
        return error("saturation_trip_s", "must be in [0, 1000] s (0 disables the trip)");
    return ok_status();
}

template <class T>
class OutputLimiter {
    static_assert(is_sample_type_v<T>, "OutputLimiter<T>: T is float or Q31");
    static constexpr bool kFloat = std::is_same_v<T, float>;
    // Internal representation: the float itself, or the Q31 raw integer.
    using Rep = std::conditional_t<kFloat, float, int32_t>;
    // Per-sample step: float, or raw LSBs (up to 2^32, so 64 bit).
    using Step = std::conditional_t<kFloat, float, int64_t>;

public:
    // hard: the board's limits; sample_rate_Hz: the rate apply() is called at
    // (turns V/s into a per-sample step); output_scale: the V <-> Q31 scale of
    // the output (ignored for float). All three are fixed for the lifetime of
    // the limiter. If they are invalid the limiter is permanently tripped
    // (kInvalidHardLimits), outputs zero, and hard_status() says why.
    constexpr OutputLimiter(const HardLimits& hard, float sample_rate_Hz,
                            SignalScale output_scale = {})
        : hard_(hard), rate_Hz_(sample_rate_Hz), scale_(output_scale) {
        hard_status_ = init_hard();
        if (!hard_status_.ok()) {
            trip_ = TripReason::kInvalidHardLimits;
            hard_lo_ = hard_hi_ = lo_ = hi_ = safe_ = last_ = Rep{};
            hard_step_ = step_ = Step{};
            return;
        }
        lo_ = hard_lo_;
        hi_ = hard_hi_;
        step_ = hard_step_;
        safe_ = clamp_rep(Rep{}, lo_, hi_);
        last_ = safe_;
        trip_ = TripReason::kNotConfigured;
    }

    // Validates c against the hard limits (and, for Q31, against the output
    // resolution) and swaps it in. On error nothing changes. The output does
    // not jump: it slews from where it is into the new range.
    constexpr Status configure(const LimitsConfig& c) {
        Setting next{};
        if (const Status s = prepare(c, next); !s.ok()) return s;
        apply_setting(next);
        return ok_status();
    }

    // configure() in two halves, so the arithmetic (double precision: soft
    // float on a Cortex-M3, thousands of instructions) can run in the main
    // loop and only the copy in the tick: prepare() validates c and computes
    // its per-sample form without changing the limiter (on error `out` is
    // untouched), apply_setting() swaps a prepared setting in.
    struct Setting {
        LimitsConfig cfg{};
        Rep lo{}, hi{};
        Step step{};
        uint32_t sat_limit = 0;
    };
    constexpr Status prepare(const LimitsConfig& c, Setting& out) const {
        if (!hard_status_.ok()) return hard_status_;
        if (const Status s = validate(c, hard_); !s.ok()) return s;

        Rep lo{}, hi{};
        Step step{};
        if constexpr (kFloat) {
            lo = c.u_min_V;
            hi = c.u_max_V;
            step = limits_detail::round_down_to_float(static_cast<double>(c.slew_V_per_s) /
                                                      static_cast<double>(rate_Hz_));
            if (step > hard_step_) step = hard_step_;
            if (step < 2.0f * range_ulp_)
                return error("slew_V_per_s",
                             "per-sample step (slew / rate) must be >= 2 float ulp of the hard range");
        } else {
            const double fs = static_cast<double>(scale_.full_scale);
            int64_t l = limits_detail::q31_raw_at_or_above(c.u_min_V, fs);
            int64_t h = limits_detail::q31_raw_at_or_below(c.u_max_V, fs);
            if (l < hard_lo_) l = hard_lo_;
            if (h > hard_hi_) h = hard_hi_;
            if (l > h) return error("u_max_V", "range is empty at the Q31 output resolution");
            lo = static_cast<int32_t>(l);
            hi = static_cast<int32_t>(h);
            step = limits_detail::floor_i64(static_cast<double>(c.slew_V_per_s) /
                                                static_cast<double>(rate_Hz_) / fs * 2147483648.0 -
                                            limits_detail::kQ31Margin);
            if (step > hard_step_) step = hard_step_;
            if (step < 2) return error("slew_V_per_s", "per-sample step (slew / rate) must be >= 2 Q31 LSB");
        }
        uint32_t sat_limit = 0;
        if (c.saturation_trip_s > 0.0f) {
            const double n = static_cast<double>(c.saturation_trip_s) * static_cast<double>(rate_Hz_);
            if (n > 4.0e9) return error("saturation_trip_s", "trip time times sample rate must be < 4e9 samples");
            // Nearest sample count: 1e-3f s at 100 kHz is 100.0000047 samples, meant as 100.
            sat_limit = static_cast<uint32_t>(limits_detail::floor_i64(n + 0.5));
            if (sat_limit == 0) sat_limit = 1;
        }

        out = Setting{c, lo, hi, step, sat_limit};
        return ok_status();
    }
    // A setting from prepare() of this limiter. Constant time.
    constexpr void apply_setting(const Setting& n) {
        cfg_ = n.cfg;
        lo_ = n.lo;
        hi_ = n.hi;
        step_ = n.step;
        safe_ = clamp_rep(Rep{}, lo_, hi_);
        sat_limit_ = n.sat_limit;
        sat_run_ = 0;
        configured_ = true;
        if (trip_ == TripReason::kNotConfigured) trip_ = TripReason::kNone;
    }

    // One sample. Never fails, constant time.
    constexpr T apply(T u) {
        Rep x{};
        bool finite = true;
        if constexpr (kFloat) {
            finite = is_finite(u);
            x = u;
        } else {
            x = u.raw();
        }
        if (!finite) {
            nonfinite_samples_ = limits_detail::sat_inc(nonfinite_samples_);
            latch(TripReason::kNonFinite);
        }

        Rep target = safe_;
        clamp_direction_ = 0;
        if (trip_ == TripReason::kNone) {
            bool clamped = true;
            if (x > hi_) { target = hi_; clamp_direction_ = 1; }
            else if (x < lo_) { target = lo_; clamp_direction_ = -1; }
            else { target = x; clamped = false; }
            if (clamped) {
                clamped_samples_ = limits_detail::sat_inc(clamped_samples_);
                if (sat_limit_ != 0 && ++sat_run_ >= sat_limit_) latch(TripReason::kSustainedSaturation);
            } else {
                sat_run_ = 0;
            }
        }

        Rep out{};
        if constexpr (kFloat) {
            // target and last_ are finite and within +-1e6: no overflow.
            float d = target - last_;
            if (d > step_) { d = step_; slew_limited_samples_ = limits_detail::sat_inc(slew_limited_samples_); }
            else if (d < -step_) { d = -step_; slew_limited_samples_ = limits_detail::sat_inc(slew_limited_samples_); }
            out = last_ + d;
        } else {
            int64_t d = int64_t{target} - last_;
            if (d > step_) { d = step_; slew_limited_samples_ = limits_detail::sat_inc(slew_limited_samples_); }
            else if (d < -step_) { d = -step_; slew_limited_samples_ = limits_detail::sat_inc(slew_limited_samples_); }
            const int64_t o = int64_t{last_} + d;
            out = static_cast<int32_t>(o < hard_lo_ ? hard_lo_ : (o > hard_hi_ ? hard_hi_ : o));
        }
        // The hard limits, last and unconditionally.
        out = clamp_rep(out, hard_lo_, hard_hi_);
        last_ = out;
        return from_rep(out);
    }

    // Latch a trip from outside (sensor fault, watchdog). The first cause is kept.
    constexpr void trip(TripReason reason = TripReason::kExternal) {
        latch(reason == TripReason::kNone ? TripReason::kExternal : reason);
    }

    // Releases a latched trip; the output then slews from where it is to the
    // command. Refused (false) while not configured or with invalid hard limits.
    constexpr bool clear_trip() {
        if (trip_ == TripReason::kInvalidHardLimits || trip_ == TripReason::kNotConfigured) return false;
        trip_ = TripReason::kNone;
        sat_run_ = 0;
        return true;
    }

    // Tell the limiter what the DAC currently outputs (e.g. at start-up), so
    // the next outputs slew from there. Clamped to the hard limits; a
    // non-finite value is taken as the safe output.
    constexpr void preset_output(T u_now) {
        if (!hard_status_.ok()) return;
        if constexpr (kFloat) {
            last_ = is_finite(u_now) ? clamp_rep(u_now, hard_lo_, hard_hi_) : safe_;
        } else {
            last_ = clamp_rep(u_now.raw(), hard_lo_, hard_hi_);
        }
    }

    // Whether the last apply() clamped the command to the configured limits:
    // +1 above u_max, -1 below u_min, 0 not (slew limiting does not count).
    // The feedback's anti-windup reads it (anti_windup.hpp).
    constexpr int clamp_direction() const { return clamp_direction_; }

    constexpr void reset_counters() { clamped_samples_ = slew_limited_samples_ = nonfinite_samples_ = 0; }

    constexpr bool tripped() const { return trip_ != TripReason::kNone; }
    constexpr TripReason trip_reason() const { return trip_; }
    constexpr bool configured() const { return configured_; }
    constexpr const LimitsConfig& config() const { return cfg_; }  // last accepted
    constexpr const HardLimits& hard_limits() const { return hard_; }
    constexpr Status hard_status() const { return hard_status_; }
    constexpr T output() const { return from_rep(last_); }     // last output
    constexpr T safe_output() const { return from_rep(safe_); }
    constexpr T hard_min() const { return from_rep(hard_lo_); }
    constexpr T hard_max() const { return from_rep(hard_hi_); }
    // Per-sample steps in sample units (float V, or Q31 raw LSBs).
    constexpr Step step_per_sample() const { return step_; }
    constexpr Step hard_step_per_sample() const { return hard_step_; }
    constexpr uint32_t clamped_samples() const { return clamped_samples_; }
    constexpr uint32_t slew_limited_samples() const { return slew_limited_samples_; }
    constexpr uint32_t nonfinite_samples() const { return nonfinite_samples_; }

private:
    static constexpr Rep clamp_rep(Rep v, Rep lo, Rep hi) { return v < lo ? lo : (v > hi ? hi : v); }
    static constexpr T from_rep(Rep r) {
        if constexpr (kFloat) return r; else return Q31::from_raw(r);
    }
    constexpr void latch(TripReason r) {
        if (trip_ == TripReason::kNone) trip_ = r;
    }

    constexpr Status init_hard() {
        if (const Status s = validate(hard_); !s.ok()) return s;
        if (!is_finite(rate_Hz_) || !(rate_Hz_ > 0.0f) || rate_Hz_ > limits_detail::kMaxRate_Hz)
            return error("sample_rate_Hz", "must be in (0, 1e8] Hz");
        const double step_d = static_cast<double>(hard_.slew_max_V_per_s) / static_cast<double>(rate_Hz_);
        if constexpr (kFloat) {
            hard_lo_ = hard_.u_min_V;
            hard_hi_ = hard_.u_max_V;
            const float a = hard_lo_ < 0.0f ? -hard_lo_ : hard_lo_;
            const float b = hard_hi_ < 0.0f ? -hard_hi_ : hard_hi_;
            range_ulp_ = limits_detail::ulp(a > b ? a : b);
            // One ulp(range) below the hard step: the rounding of last + d
            // (at most half an ulp of the output) then cannot exceed it.
            hard_step_ = limits_detail::round_down_to_float(step_d - static_cast<double>(range_ulp_));
            if (!(hard_step_ >= 4.0f * range_ulp_))
                return error("slew_max_V_per_s", "per-sample step (slew / rate) must be >= 4 float ulp of the hard range");
        } else {
            const float fs = scale_.full_scale;
            if (!is_finite(fs) || !(fs > 0.0f) || fs > limits_detail::kMaxAbsVolt)
                return error("full_scale", "output scale must be in (0, 1e6] V");
            const double fsd = static_cast<double>(fs);
            const int64_t l = limits_detail::q31_raw_at_or_above(hard_.u_min_V, fsd);
            const int64_t h = limits_detail::q31_raw_at_or_below(hard_.u_max_V, fsd);
            if (l > h || l > Q31::kMaxRaw || h < Q31::kMinRaw)
                return error("u_min_V", "hard range does not intersect the Q31 output full scale");
            hard_lo_ = static_cast<int32_t>(l < Q31::kMinRaw ? Q31::kMinRaw : l);
            hard_hi_ = static_cast<int32_t>(h > Q31::kMaxRaw ? Q31::kMaxRaw : h);
            int64_t s = limits_detail::floor_i64(step_d / fsd * 2147483648.0 - limits_detail::kQ31Margin);
            if (s > (int64_t{1} << 32)) s = int64_t{1} << 32;  // more than the whole range: no limit
            hard_step_ = s;
            if (hard_step_ < 4) return error("slew_max_V_per_s", "per-sample step (slew / rate) must be >= 4 Q31 LSB");
        }
        return ok_status();
    }

    HardLimits hard_{};
    float rate_Hz_ = 0.0f;
    SignalScale scale_{};
    Status hard_status_{};
    LimitsConfig cfg_{};
    bool configured_ = false;

    Rep hard_lo_{}, hard_hi_{};
    Step hard_step_{};
    float range_ulp_ = 0.0f;  // float only
    Rep lo_{}, hi_{}, safe_{};
    Step step_{};
    uint32_t sat_limit_ = 0, sat_run_ = 0;
    int8_t clamp_direction_ = 0;

    Rep last_{};
    TripReason trip_ = TripReason::kNone;
    uint32_t clamped_samples_ = 0;
    uint32_t slew_limited_samples_ = 0;
    uint32_t nonfinite_samples_ = 0;
};

}  // namespace piezoloop
