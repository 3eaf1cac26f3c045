// Reference trajectories for the loop: sine, triangle, raster sawtooth,
// square, step sequence, and a user wave table.
//
//   r[n] = offset_um + amplitude_um * w(phase[n])          w in [-1, 1]
//
// Phase: a 32-bit accumulator (2^32 = one cycle). The float and the Q31
// generator compute the shape w from the same integer phase in integer
// arithmetic (Q31), so both are deterministic on every target and differ only
// by the final scaling. No libm: the sine comes from sine_table.hpp.
//
// Exact periods: a plain 32-bit accumulator cannot represent 1 kHz at 100 kHz
// (2^32/100 is not an integer), so the generator would drift by a few phase
// LSBs per cycle and a repetitive controller would see a reference that is
// not N-periodic. Instead the increment per sample is the rational
// 2^32 * num / den with num/den the continued-fraction approximation of
// f / f_s (den < 2^31, exact whenever f / f_s is such a rational, e.g. every f
// that divides f_s): the integer part is added every sample and the remainder
// is carried by a Bresenham error term. After den samples the phase has
// advanced by exactly num cycles. Otherwise the frequency error is below
// f_s / (den * 2^31), far below a 32-bit accumulator's f_s / 2^33.
//
// Shapes at phase fraction x in [0, 1) (conventions of scipy.signal):
//   kSine      sin(2 pi x)
//   kTriangle  -1 at x = 0, +1 at x = 1/2, linear in between (sawtooth width 1/2)
//   kRaster    rises -1 -> +1 over [0, 1 - return_fraction), falls back over the rest
//   kSquare    +1 for x < duty, else -1
//   kSteps     table[floor(x * n)]: a step sequence, each value held for 1/n cycle
//   kTable     table linearly interpolated, periodic (point n wraps to point 0)
// start_phase_cycles shifts the phase at which the trajectory starts (e.g.
// 0.75 starts a sine at its minimum, so a stage resting at offset - amplitude
// starts without a step).
//
// Accuracy (shape w in units of the amplitude): sine <= 2.95e-7 (table, see
// sine_table.hpp); triangle / raster <= 2 Q31 LSB; square exact (+-(1 - 2^-31));
// table values rounded to Q31 (0.5 LSB) and interpolated to 1 LSB. The phase
// of each sample is the exact rational phase rounded up to an LSB (see
// phase()), < 2^-32 cycle. Output: float offset + A * w rounds to within
// 2 float ulp of |offset| + A; Q31 off_q + amp_q * w to within 1.5 Q31 LSB.
//
// cycles > 0: after that many full cycles (counted from the start phase) the
// output holds the start value w(start_phase), which is also the value the
// waveform ends each cycle on, and done() becomes true.
#pragma once

#include <array>
#include <bit>
#include <cstddef>
#include <cstdint>
#include <span>
#include <type_traits>

#include "piezoloop/det_math.hpp"
#include "piezoloop/q31.hpp"
#include "piezoloop/sample.hpp"
#include "piezoloop/sine_table.hpp"
#include "piezoloop/status.hpp"

namespace piezoloop {

enum class Waveform : uint8_t { kSine, kTriangle, kRaster, kSquare, kSteps, kTable };

struct TrajectoryConfig {
    Waveform waveform = Waveform::kSine;
    float amplitude_um = 0.0f;        // peak (half of peak-to-peak), >= 0
    float offset_um = 0.0f;
    float frequency_Hz = 1.0f;        // (0, sample_rate_Hz / 2)
    float sample_rate_Hz = 100000.0f;
    uint32_t cycles = 0;              // 0 = forever
    float start_phase_cycles = 0.0f;  // [0, 1)
    float return_fraction = 0.1f;     // kRaster: fly-back share of the period
    float duty = 0.5f;                // kSquare: share of the period at +amplitude
    // kSteps / kTable: normalised values in [-1, 1]; copied at configure(),
    // the caller's memory is not referenced afterwards.
    std::span<const float> table{};
};

namespace trajectory_detail {

inline constexpr double kTwo32 = 4294967296.0;
inline constexpr float kMaxAbs_um = 1.0e6f;  // 1 m: anything beyond is a unit error
// Shares of a period for the raster fly-back and the square duty: both
// segments must be at least 2^-16 of a cycle (keeps the slopes in 32 bits).
inline constexpr float kMinShare = 1.0f / 65536.0f;

// Phase advance per sample: inc + rem / den phase LSBs (2^32 LSB = 1 cycle).
struct PhaseStep {
    uint32_t inc = 0;
    uint32_t rem = 0;
    uint32_t den = 1;
};

// Continued-fraction approximation num/den of ratio in (0, 1/2), den < 2^31.
// Returns false if ratio is below what that can represent (num would be 0).
constexpr bool rational_phase_step(double ratio, PhaseStep& out) {
    constexpr uint64_t kMaxDen = 0x7fffffffu;
    uint64_t h_prev = 0, h = 1;  // numerators h_{n-2}, h_{n-1} (start: h_{-2} = 0, h_{-1} = 1)
    uint64_t k_prev = 1, k = 0;  // denominators (k_{-2} = 1, k_{-1} = 0)
    uint64_t best_h = 0, best_k = 1;
    double best_err = ratio;
    double y = ratio;
    for (int it = 0; it < 64; ++it) {
        if (!(y < 4.0e18)) break;
        const uint64_t a = static_cast<uint64_t>(y);  // floor, y >= 0
        if (a != 0 && k > (kMaxDen - k_prev) / a) break;  // next denominator too large
        const uint64_t h_next = a * h + h_prev;
        const uint64_t k_next = a * k + k_prev;
        h_prev = h; h = h_next;
        k_prev = k; k = k_next;
        const double approx = static_cast<double>(h) / static_cast<double>(k);
        const double err = approx > ratio ? approx - ratio : ratio - approx;
        if (h != 0 && err <= best_err) { best_err = err; best_h = h; best_k = k; }
        // Exact up to the rounding of ratio itself (f and f_s are floats).
        if (err <= ratio * 0x1p-50) break;
        const double f = y - static_cast<double>(a);
        if (!(f > 0.0)) break;
        y = 1.0 / f;
    }
    if (best_h == 0) return false;
    const uint64_t scaled = best_h << 32;  // best_h < 2^30: fits
    out.den = static_cast<uint32_t>(best_k);
    out.inc = static_cast<uint32_t>(scaled / best_k);
    out.rem = static_cast<uint32_t>(scaled % best_k);
    return true;
}

// A linear segment of the phase, 0 .. len-1 -> 0 .. 2^32 (exclusive), as
// (x * mul) >> shift with mul < 2^32 (one 32x32->64 multiply per sample).
// mul = floor(2^(32+shift) / len) with 2^shift < len, so the result is at
// most 2 LSB below the exact x * 2^32 / len.
struct Ramp {
    uint32_t mul = 0;
    int shift = 0;
};
constexpr Ramp make_ramp(uint64_t len) {  // 2 <= len <= 2^32 - 1
    Ramp r;
    r.shift = static_cast<int>(std::bit_width(len - 1)) - 1;
    r.mul = static_cast<uint32_t>((uint64_t{1} << (32 + r.shift)) / len);
    return r;
}
// x * mul < 2^(32 + shift): the result fits 32 bits, and the shift
// (0 .. 31) is done on the product's two words (a 64-bit shift by a
// variable amount costs twice the instructions on a 32-bit core).
constexpr uint32_t apply_ramp(Ramp r, uint32_t x) {  // x < len
    const uint64_t v = uint64_t{x} * r.mul;
    const uint32_t lo = static_cast<uint32_t>(v), hi = static_cast<uint32_t>(v >> 32);
    return (lo >> r.shift) | ((hi << 1) << (31 - r.shift));  // hi << (32 - shift), 0 for shift 0
}

constexpr uint32_t share_to_phase(double share) {  // share in [2^-16, 1 - 2^-16]
    return static_cast<uint32_t>(share * kTwo32 + 0.5);
}

}  // namespace trajectory_detail

template <class T, std::size_t TableCapacity = 256>
class TrajectoryGenerator {
    static_assert(is_sample_type_v<T>, "TrajectoryGenerator<T>: T is float or Q31");
    static_assert(TableCapacity >= 1 && TableCapacity < (std::size_t{1} << 24), "table capacity");
    static constexpr bool kFloat = std::is_same_v<T, float>;

public:
    // out_scale: µm <-> Q31 of the reference signal (ignored for float).
    // Until configure() succeeds the output is zero.
    explicit constexpr TrajectoryGenerator(SignalScale out_scale = {}) : scale_(out_scale) {}

    // Validates and swaps in c, then restarts at the start phase, cycle 0.
    // On error nothing changes.
    constexpr Status configure(const TrajectoryConfig& c) {
        using namespace trajectory_detail;
        if (!is_finite(c.sample_rate_Hz) || !(c.sample_rate_Hz > 0.0f) || c.sample_rate_Hz > 1.0e9f)
            return error("sample_rate_Hz", "must be in (0, 1e9] Hz");
        PhaseStep ps;
        if (const Status s = frequency_step(c.frequency_Hz, c.sample_rate_Hz, ps); !s.ok()) return s;
        if (!is_finite(c.amplitude_um) || c.amplitude_um < 0.0f || c.amplitude_um > kMaxAbs_um)
            return error("amplitude_um", "must be in [0, 1e6] um");
        if (!is_finite(c.offset_um) || c.offset_um < -kMaxAbs_um || c.offset_um > kMaxAbs_um)
            return error("offset_um", "must be finite and within +-1e6 um");
        if (!is_finite(c.start_phase_cycles) || c.start_phase_cycles < 0.0f || !(c.start_phase_cycles < 1.0f))
            return error("start_phase_cycles", "must be in [0, 1)");

        Ramp rise{}, fall{};
        uint32_t split = 0x80000000u;  // phase where the rising part ends / the square flips
        switch (c.waveform) {
            case Waveform::kSine:
                break;
            case Waveform::kTriangle:
                rise = make_ramp(split);
                fall = make_ramp(split);
                break;
            case Waveform::kRaster:
                if (!is_finite(c.return_fraction) || c.return_fraction < kMinShare ||
                    c.return_fraction > 1.0f - kMinShare)
                    return error("return_fraction", "must be in [2^-16, 1 - 2^-16]");
                split = share_to_phase(1.0 - static_cast<double>(c.return_fraction));
                rise = make_ramp(split);
                fall = make_ramp((uint64_t{1} << 32) - split);
                break;
            case Waveform::kSquare:
                if (!is_finite(c.duty) || c.duty < kMinShare || c.duty > 1.0f - kMinShare)
                    return error("duty", "must be in [2^-16, 1 - 2^-16]");
                split = share_to_phase(static_cast<double>(c.duty));
                break;
            case Waveform::kSteps:
            case Waveform::kTable:
                if (c.table.empty() || c.table.size() > TableCapacity)
                    return error("table", "size must be in [1, table capacity]");
                for (const float v : c.table) {
                    if (!is_finite(v) || v < -1.0f || v > 1.0f)
                        return error("table", "values must be finite and in [-1, 1]");
                }
                break;
            default:
                return error("waveform", "unknown waveform");
        }

        Q31 amp_q{}, off_q{};
        if constexpr (!kFloat) {
            const float fs = scale_.full_scale;
            if (!is_finite(fs) || !(fs > 0.0f)) return error("full_scale", "output scale must be > 0 and finite");
            const double a = static_cast<double>(c.amplitude_um), o = static_cast<double>(c.offset_um);
            if ((o < 0.0 ? -o : o) + a > static_cast<double>(fs))
                return error("amplitude_um", "|offset| + amplitude must be <= the Q31 full scale");
            amp_q = Q31::from_double(a / static_cast<double>(fs));
            off_q = Q31::from_double(o / static_cast<double>(fs));
        }

        // Commit.
        cfg_ = c;
        cfg_.table = {};
        if (c.waveform == Waveform::kSteps || c.waveform == Waveform::kTable) {
            table_size_ = static_cast<uint32_t>(c.table.size());
            for (std::size_t i = 0; i < c.table.size(); ++i) table_[i] = Q31::from_float(c.table[i]).raw();
        } else {
            table_size_ = 0;
        }
        step_ = ps;
        rise_ = rise;
        fall_ = fall;
        split_ = split;
        amp_f_ = c.amplitude_um;
        off_f_ = c.offset_um;
        amp_q_ = amp_q;
        off_q_ = off_q;
        // start_phase_cycles <= 1 - 2^-24, so this is at most 2^32 - 256.
        start_ = static_cast<uint32_t>(static_cast<double>(c.start_phase_cycles) * kTwo32 + 0.5);
        configured_ = true;
        restart();
        return ok_status();
    }

    // Live frequency change: the phase carries on (no jump), the cycle count
    // carries on. The fractional phase (Bresenham term) is rescaled to the
    // new denominator, so the phase error stays below one LSB.
    constexpr Status set_frequency(float frequency_Hz) {
        if (!configured_) return error("frequency_Hz", "configure the generator first");
        trajectory_detail::PhaseStep ps;
        if (const Status s = frequency_step(frequency_Hz, cfg_.sample_rate_Hz, ps); !s.ok()) return s;
        // Rescale the fractional phase err/den to the new denominator,
        // rounded up so that phase() (which rounds the exact phase up) does
        // not move; a fraction that does not fit below the new den carries.
        uint32_t carry_lsb = 0;
        if (err_ != 0) {
            const uint64_t e = (uint64_t{err_} * ps.den + step_.den - 1) / step_.den;
            if (e >= ps.den) { err_ = 0; carry_lsb = 1; } else { err_ = static_cast<uint32_t>(e); }
        }
        advance_acc(carry_lsb);
        step_ = ps;
        cfg_.frequency_Hz = frequency_Hz;
        return ok_status();
    }

    // Back to the start phase, cycle 0.
    constexpr void restart() {
        acc_ = 0;
        err_ = 0;
        cycles_done_ = 0;
        done_ = false;
        hold_ = value_at(start_);
    }

    // Output at the current phase, then advance by one sample. Always
    // inlined, with what it calls: the tick calls it from two places (a
    // wave, the end of its approach), and GCC would otherwise make a call
    // of it, paid on every tick.
    [[gnu::always_inline]] constexpr T step() {
        if (done_) return hold_;
        const T out = value_at(phase());
        advance_acc(step_.inc + carry());
        return out;
    }

    constexpr bool done() const { return done_; }
    constexpr bool configured() const { return configured_; }
    constexpr uint32_t cycles_completed() const { return cycles_done_; }
    // Phase of the next output (start phase included), 2^32 = one cycle: the
    // exact rational phase rounded *up* to an LSB, so a sample that falls
    // exactly on a level boundary (k/n of a cycle for kSteps, the duty, the
    // raster turn) takes the new level, as in scipy.signal. Error < 1 LSB.
    constexpr uint32_t phase() const { return start_ + acc_ + (err_ != 0 ? 1u : 0u); }
    // The frequency actually produced: f_s * num / den.
    constexpr double actual_frequency_Hz() const {
        if (!configured_) return 0.0;
        return static_cast<double>(cfg_.sample_rate_Hz) *
               ((static_cast<double>(step_.inc) + static_cast<double>(step_.rem) / step_.den) /
                trajectory_detail::kTwo32);
    }
    // Samples after which the phase repeats exactly (the denominator).
    constexpr uint32_t exact_period_samples() const { return step_.den; }
    // The first output after configure() or restart(): the value at the start phase.
    constexpr T start_value() const { return value_at(start_); }
    // Last accepted configuration (its table span is empty: the values live here).
    constexpr const TrajectoryConfig& config() const { return cfg_; }

    // Normalised shape w(phase) as Q31 raw (no state change).
    [[gnu::always_inline]] constexpr int32_t shape_q31(uint32_t p) const {
        using trajectory_detail::apply_ramp;
        switch (cfg_.waveform) {
            case Waveform::kSine:
                return sine_q31(p);
            case Waveform::kTriangle:
            case Waveform::kRaster:
                if (p < split_) return static_cast<int32_t>(static_cast<int64_t>(apply_ramp(rise_, p)) - 0x80000000LL);
                return sat31(0x80000000LL - static_cast<int64_t>(apply_ramp(fall_, p - split_)));
            case Waveform::kSquare:
                return p < split_ ? Q31::kMaxRaw : -Q31::kMaxRaw;
            case Waveform::kSteps:
            case Waveform::kTable: {
                if (table_size_ == 0) return 0;
                const uint64_t pn = uint64_t{p} * table_size_;
                const uint32_t i = static_cast<uint32_t>(pn >> 32);
                if (cfg_.waveform == Waveform::kSteps) return table_[i];
                const uint32_t j = i + 1 == table_size_ ? 0 : i + 1;
                // 31-bit fraction so that the product of the (up to 33-bit)
                // difference stays below 2^63.
                const int64_t frac = static_cast<int64_t>(static_cast<uint32_t>(pn) >> 1);
                const int64_t a = table_[i], b = table_[j];
                return static_cast<int32_t>(a + (((b - a) * frac + (int64_t{1} << 30)) >> 31));
            }
        }
        return 0;
    }

    // Output at a given phase (no state change).
    [[gnu::always_inline]] constexpr T value_at(uint32_t p) const {
        const int32_t w = shape_q31(p);
        if constexpr (kFloat) {
            return off_f_ + amp_f_ * (static_cast<float>(w) * 0x1p-31f);
        } else {
            return off_q_ + amp_q_ * Q31::from_raw(w);
        }
    }

private:
    static constexpr int32_t sat31(int64_t v) {
        return v > Q31::kMaxRaw ? Q31::kMaxRaw : (v < Q31::kMinRaw ? Q31::kMinRaw : static_cast<int32_t>(v));
    }

    [[gnu::always_inline]] constexpr void advance_acc(uint32_t add) {
        const uint32_t s = acc_ + add;  // add < 2^31: at most one wrap
        const bool wrapped = s < acc_;
        acc_ = s;
        if (wrapped) {  // one full cycle since the start phase
            if (cycles_done_ != 0xffffffffu) ++cycles_done_;
            if (cfg_.cycles != 0 && cycles_done_ >= cfg_.cycles) done_ = true;
        }
    }

    // Bresenham carry of the fractional phase increment.
    [[gnu::always_inline]] constexpr uint32_t carry() {
        err_ += step_.rem;  // both < den < 2^31: no overflow
        if (err_ >= step_.den) { err_ -= step_.den; return 1u; }
        return 0u;
    }

    static constexpr Status frequency_step(float f_Hz, float rate_Hz, trajectory_detail::PhaseStep& ps) {
        if (!is_finite(f_Hz) || !(f_Hz > 0.0f) ||
            !(static_cast<double>(f_Hz) < 0.5 * static_cast<double>(rate_Hz)))
            return error("frequency_Hz", "must be in (0, sample_rate_Hz / 2)");
        if (!trajectory_detail::rational_phase_step(static_cast<double>(f_Hz) / static_cast<double>(rate_Hz), ps))
            return error("frequency_Hz", "must be >= sample_rate_Hz / 2^31");
        return ok_status();
    }

    SignalScale scale_{};
    TrajectoryConfig cfg_{};
    bool configured_ = false;

    // Configuration derived at configure() time.
    trajectory_detail::PhaseStep step_{};
    trajectory_detail::Ramp rise_{}, fall_{};
    uint32_t split_ = 0x80000000u;
    uint32_t start_ = 0;
    float amp_f_ = 0.0f, off_f_ = 0.0f;
    Q31 amp_q_{}, off_q_{};
    std::array<int32_t, TableCapacity> table_{};
    uint32_t table_size_ = 0;

    // State.
    uint32_t acc_ = 0;   // phase since the start phase
    uint32_t err_ = 0;   // Bresenham numerator, < den
    uint32_t cycles_done_ = 0;
    bool done_ = false;
    T hold_{};
};

}  // namespace piezoloop
