// Excitation for frequency-response measurements: a signal d added
// to the command or to the reference by the pipeline (pipeline.hpp).
//
//   d[n] = offset + amplitude * w[n]          w in [-1, 1]
//
// Three shapes, all deterministic (integer or IEEE double arithmetic only, no
// libm), so host and boards compute the same bits:
//
// - Periodic multisine (Pintelon & Schoukens, System Identification, 2nd ed.
//   2012, ch. 2 and 4): one period of N samples with lines at the DFT bins
//   k1..k2 of N, equal amplitudes and Schroeder's phases
//       w[n] ∝ sum_{k=k1..k2} cos(2 pi k n / N + phi_k),
//       phi_k = -pi (k - k1)(k - k1 + 1) / K,  K = k2 - k1 + 1
//   (M. R. Schroeder, "Synthesis of low-peak-factor signals and binary
//   sequences with low autocorrelation", IEEE Trans. Inf. Theory 16(1), 1970),
//   which keeps the crest factor near 1.7 instead of sqrt(2K) for equal phases.
//   The period is tabulated once at configure (N <= TableCapacity) in integer
//   arithmetic from exact phases and the core's sine table, then normalised
//   to a peak of 1 - 2^-31 (see tabulate_multisine()). Because the table holds
//   a whole number of periods of every line, its DFT has energy at the chosen
//   bins only (up to the rounding, ~1e-5 of a line), so a per-period DFT has
//   no leakage.
// - Logarithmic swept sine from f1 to f2 over `period_samples` samples
//   (instantaneous frequency f1 (f2/f1)^(n/L)): the per-sample phase increment
//   (a 2^-64-cycle fixed point held in double) is multiplied by the constant
//   ratio (f2/f1)^(1/L) each sample; sin from the sine table.
// - PRBS: a maximum-length Fibonacci LFSR of order n (period 2^n - 1 bits,
//   2^(n-1) ones and 2^(n-1) - 1 zeros), taps from Xilinx XAPP052 (Alfke 1996),
//   each bit held for `prbs_hold` samples; w = +1 for a one, -1 for a zero.
//
// Three shapes for steps and hysteresis loops, w in [0, 1] starting at 0, so
// d = offset + amplitude * w starts at the offset and amplitude is the
// peak-to-peak above it. Their sample n of a period of N comes from the
// phase p = floor(n 2^32 / N) (exact integer arithmetic, as the multisine's):
// - kStep:     w = 0 for the first half of the period, 1 for the second
//              (a step at n = ceil(N / 2), held as long as the level before it);
// - kTriangle: w rises linearly from 0 to 1 at mid-period and falls back;
// - kRaisedCosine: w = (1 - cos 2 pi n / N) / 2, the triangle's smooth twin
//              (zero slope at the turning points).
//
// periods > 0: after that many periods the output returns to `offset` and
// done() is true. The generator is configured outside the tick; step() is
// the tick's part.
#pragma once

#include <array>
#include <bit>
#include <cstddef>
#include <cstdint>
#include <type_traits>

#include "piezoloop/det_math.hpp"
#include "piezoloop/q31.hpp"
#include "piezoloop/sample.hpp"
#include "piezoloop/sine_table.hpp"
#include "piezoloop/status.hpp"

namespace piezoloop {

enum class ExcitationSignal : uint8_t { kMultisine = 0, kSweep, kPrbs, kStep, kTriangle, kRaisedCosine };
// Where the pipeline adds d: to the command before the limiter (open loop:
// u = d, with offset the bias; closed loop: u = controller output + d), or to
// the reference before feedforward and feedback.
enum class ExcitationPoint : uint8_t { kCommand = 0, kReference };

struct ExcitationConfig {
    ExcitationSignal signal = ExcitationSignal::kMultisine;
    ExcitationPoint point = ExcitationPoint::kCommand;
    float amplitude = 0.0f;  // peak of amplitude * w (V at the command, µm at the reference); < 0 inverts w
    float offset = 0.0f;     // added throughout (the bias of an open-loop measurement)
    float sample_rate_Hz = 100000.0f;
    uint32_t period_samples = 0;  // multisine, step, triangle, raised cosine: N; sweep: its length L
    uint32_t first_bin = 1;       // multisine: k1 >= 1
    uint32_t last_bin = 1;        // multisine: k2 in [k1, N/2)
    float f1_Hz = 0.0f;           // sweep: start, > 0
    float f2_Hz = 0.0f;           // sweep: end, in (f1, rate / 2)
    uint32_t prbs_order = 10;     // PRBS: n in [2, 24]
    uint32_t prbs_hold = 1;       // PRBS: samples per bit, >= 1
    uint32_t periods = 0;         // 0: until stopped
};

namespace excitation_detail {

inline constexpr float kMaxAbs = 1.0e6f;
// The longest period of any shape, samples: counted in 32 bits.
inline constexpr uint64_t kMaxPeriodSamples = 0xffffffffu;

// Feedback taps (1-based bit positions) of maximum-length LFSRs, XAPP052
// table 3; entry n is for order n, 0 marks an unused tap.
inline constexpr std::array<std::array<uint8_t, 4>, 25> kPrbsTaps = {{
    {0, 0, 0, 0},     {0, 0, 0, 0},      {2, 1, 0, 0},      {3, 2, 0, 0},     {4, 3, 0, 0},
    {5, 3, 0, 0},     {6, 5, 0, 0},      {7, 6, 0, 0},      {8, 6, 5, 4},     {9, 5, 0, 0},
    {10, 7, 0, 0},    {11, 9, 0, 0},     {12, 6, 4, 1},     {13, 4, 3, 1},    {14, 5, 3, 1},
    {15, 14, 0, 0},   {16, 15, 13, 4},   {17, 14, 0, 0},    {18, 11, 0, 0},   {19, 6, 2, 1},
    {20, 17, 0, 0},   {21, 19, 0, 0},    {22, 21, 0, 0},    {23, 18, 0, 0},   {24, 23, 22, 17},
}};

constexpr uint32_t prbs_mask(uint32_t order) {
    uint32_t m = 0;
    for (const uint8_t t : kPrbsTaps[order])
        if (t != 0) m |= 1u << (t - 1u);
    return m;
}

// ln x for finite x > 0 with IEEE double operations only (configure time):
// x = m 2^e with m in [sqrt(1/2), sqrt(2)), ln m = 2 atanh((m - 1)/(m + 1))
// by its series (|t| < 0.172: 30 terms are far below an ulp).
constexpr double det_log(double x) {
    constexpr double kLn2 = 0.69314718055994530942;
    uint64_t bits = std::bit_cast<uint64_t>(x);
    int e = static_cast<int>((bits >> 52) & 0x7ff) - 1023;
    bits = (bits & 0x000fffffffffffffull) | 0x3ff0000000000000ull;  // m in [1, 2)
    double m = std::bit_cast<double>(bits);
    if (m > 1.4142135623730951) {
        m *= 0.5;
        ++e;
    }
    const double t = (m - 1.0) / (m + 1.0);
    const double t2 = t * t;
    double term = t, sum = 0.0;
    for (int k = 1; k < 60; k += 2) {
        sum += term / k;
        term *= t2;
    }
    return 2.0 * sum + e * kLn2;
}

}  // namespace excitation_detail

template <class T, std::size_t TableCapacity = 1024>
class ExcitationGenerator {
    static_assert(is_sample_type_v<T>, "ExcitationGenerator<T>: T is float or Q31");
    static_assert(TableCapacity >= 4 && TableCapacity < (std::size_t{1} << 24), "table capacity");
    static constexpr bool kFloat = std::is_same_v<T, float>;

public:
    static constexpr std::size_t kTableCapacity = TableCapacity;

    // out_scale: the physical unit of d <-> Q31 (ignored for float).
    explicit constexpr ExcitationGenerator(SignalScale out_scale = {}) : scale_(out_scale) {}
    // The unit of d depends on where it is added; set before configure().
    constexpr void set_output_scale(SignalScale out_scale) { scale_ = out_scale; }

    // Validates c, tabulates a multisine's period, and restarts. On error
    // nothing changes. Main-loop context (a multisine costs K N table lookups).
    constexpr Status configure(const ExcitationConfig& c) {
        using namespace excitation_detail;
        if (!is_finite(c.sample_rate_Hz) || !(c.sample_rate_Hz > 0.0f) || c.sample_rate_Hz > 1.0e9f)
            return error("sample_rate_Hz", "must be in (0, 1e9] Hz");
        if (!is_finite(c.amplitude) || c.amplitude < -kMaxAbs || c.amplitude > kMaxAbs)
            return error("amplitude", "must be within +-1e6 (negative: the shape inverted)");
        if (!is_finite(c.offset) || c.offset < -kMaxAbs || c.offset > kMaxAbs)
            return error("offset", "must be finite and within +-1e6");
        double sweep_ratio = 1.0, sweep_inc = 0.0;
        switch (c.signal) {
            case ExcitationSignal::kMultisine:
                if (c.period_samples < 4 || c.period_samples > TableCapacity)
                    return error("period_samples", "multisine: must be in [4, table capacity]");
                // 2 k2 < N in 64 bits: in 32, k2 = 2^31 would wrap to 0 and pass.
                if (c.first_bin < 1 || c.last_bin < c.first_bin || 2u * uint64_t{c.last_bin} >= c.period_samples)
                    return error("last_bin", "multisine: bins must satisfy 1 <= first_bin <= last_bin < N / 2");
                break;
            case ExcitationSignal::kSweep: {
                if (c.period_samples < 2) return error("period_samples", "sweep: must be >= 2 samples");
                const double nyq = 0.5 * static_cast<double>(c.sample_rate_Hz);
                if (!is_finite(c.f1_Hz) || !(c.f1_Hz > 0.0f)) return error("f1_Hz", "sweep: must be > 0");
                if (!is_finite(c.f2_Hz) || !(c.f2_Hz > c.f1_Hz) || !(static_cast<double>(c.f2_Hz) < nyq))
                    return error("f2_Hz", "sweep: must be in (f1_Hz, sample_rate_Hz / 2)");
                // Per sample the increment grows by (f2/f1)^(1/L).
                sweep_ratio = det_exp(det_log(static_cast<double>(c.f2_Hz) / static_cast<double>(c.f1_Hz)) /
                                      static_cast<double>(c.period_samples));
                sweep_inc = static_cast<double>(c.f1_Hz) / static_cast<double>(c.sample_rate_Hz) * 0x1p64;
                break;
            }
            case ExcitationSignal::kPrbs:
                if (c.prbs_order < 2 || c.prbs_order > 24) return error("prbs_order", "must be in [2, 24]");
                if (c.prbs_hold < 1 || c.prbs_hold > (1u << 16)) return error("prbs_hold", "must be in [1, 65536]");
                // The period (2^n - 1) h is counted in 32 bits (period_length()).
                if (((uint64_t{1} << c.prbs_order) - 1u) * c.prbs_hold > kMaxPeriodSamples)
                    return error("prbs_hold", "prbs: the period (2^prbs_order - 1) * prbs_hold must be < 2^32 samples");
                break;
            case ExcitationSignal::kStep:
            case ExcitationSignal::kTriangle:
            case ExcitationSignal::kRaisedCosine:
                if (c.period_samples < 2) return error("period_samples", "step, triangle, raised cosine: must be >= 2 samples");
                break;
            default:
                return error("signal", "must be multisine, sweep, prbs, step, triangle or raised cosine");
        }
        // The step, triangle and raised cosine run as a bipolar w' = 2 w - 1
        // about their mid-level: d = (offset + amplitude/2) + (amplitude/2) w',
        // so a Q31 d may span the whole full scale (from -fs to +fs) while
        // the factors stay within it.
        const bool unipolar = c.signal == ExcitationSignal::kStep || c.signal == ExcitationSignal::kTriangle ||
                              c.signal == ExcitationSignal::kRaisedCosine;
        const float amp_f = unipolar ? 0.5f * c.amplitude : c.amplitude;
        const float off_f = unipolar ? c.offset + 0.5f * c.amplitude : c.offset;
        Q31 amp_q{}, off_q{};
        if constexpr (!kFloat) {
            const double fs = static_cast<double>(scale_.full_scale);
            if (!(fs > 0.0)) return error("full_scale", "output scale must be > 0");
            const double o = static_cast<double>(off_f);
            const double a = static_cast<double>(amp_f);
            if ((o < 0.0 ? -o : o) + (a < 0.0 ? -a : a) > fs)
                return error("amplitude", "the excitation's range must lie within the Q31 full scale");
            amp_q = Q31::from_double(a / fs);
            off_q = Q31::from_double(o / fs);
        }
        // Commit.
        cfg_ = c;
        amp_f_ = amp_f;
        off_f_ = off_f;
        rest_w_ = unipolar ? -Q31::kMaxRaw : 0;  // w' of the offset itself
        amp_q_ = amp_q;
        off_q_ = off_q;
        sweep_ratio_ = sweep_ratio;
        sweep_inc0_ = sweep_inc;
        if (c.signal == ExcitationSignal::kMultisine) tabulate_multisine();
        if (c.signal == ExcitationSignal::kPrbs) lfsr_mask_ = excitation_detail::prbs_mask(c.prbs_order);
        if (c.period_samples > 0) {
            const uint64_t turn = uint64_t{1} << 32;
            ramp_q_ = static_cast<uint32_t>(turn / c.period_samples);
            ramp_r_ = static_cast<uint32_t>(turn % c.period_samples);
        }
        configured_ = true;
        restart();
        return ok_status();
    }

    // Back to sample 0 of period 0.
    constexpr void restart() {
        n_ = 0;
        periods_done_ = 0;
        done_ = false;
        sweep_phase_ = 0;
        sweep_inc_ = sweep_inc0_;
        // Any non-zero state; all ones as in XAPP052's XNOR reset. (Another
        // shape's prbs_order is unchecked, and unused.)
        lfsr_ = cfg_.signal == ExcitationSignal::kPrbs ? (1u << cfg_.prbs_order) - 1u : 1u;
        hold_n_ = 0;
        bit_ = 1;
        ramp_phase_ = 0;
        ramp_rem_ = 0;
    }

    // Output, then advance by one sample. After the last period: the offset.
    constexpr T step() {
        if (done_) return value_of(rest_w_);
        int32_t w = 0;
        switch (cfg_.signal) {
            case ExcitationSignal::kMultisine:
                w = table_[n_];
                break;
            case ExcitationSignal::kSweep:
                w = sine_q31(static_cast<uint32_t>(sweep_phase_ >> 32));
                sweep_phase_ += static_cast<uint64_t>(sweep_inc_);
                sweep_inc_ *= sweep_ratio_;
                break;
            case ExcitationSignal::kPrbs:
                if (hold_n_ == 0) bit_ = next_bit();
                if (++hold_n_ == cfg_.prbs_hold) hold_n_ = 0;
                w = bit_ != 0 ? Q31::kMaxRaw : -Q31::kMaxRaw;
                break;
            case ExcitationSignal::kStep:
            case ExcitationSignal::kTriangle:
            case ExcitationSignal::kRaisedCosine:
                w = ramp_shape();
                break;
        }
        if (++n_ == period_length()) {
            n_ = 0;
            ramp_phase_ = 0;
            ramp_rem_ = 0;
            sweep_phase_ = 0;
            sweep_inc_ = sweep_inc0_;
            if (periods_done_ != 0xffffffffu) ++periods_done_;
            if (cfg_.periods != 0 && periods_done_ >= cfg_.periods) done_ = true;
        }
        return value_of(w);
    }

    // Samples per period: N, L, or (2^n - 1) * hold.
    constexpr uint32_t period_length() const {
        if (cfg_.signal == ExcitationSignal::kPrbs) return ((1u << cfg_.prbs_order) - 1u) * cfg_.prbs_hold;
        return cfg_.period_samples;
    }
    constexpr bool done() const { return done_; }
    constexpr bool configured() const { return configured_; }
    constexpr uint32_t periods_completed() const { return periods_done_; }
    constexpr const ExcitationConfig& config() const { return cfg_; }
    // The tabulated multisine period, normalised shape as Q31 raw.
    constexpr int32_t table_q31(uint32_t n) const { return table_[n]; }

private:
    constexpr T value_of(int32_t w) const {
        if constexpr (kFloat) return off_f_ + amp_f_ * (static_cast<float>(w) * 0x1p-31f);
        else return off_q_ + amp_q_ * Q31::from_raw(w);
    }

    // Step, triangle, raised cosine (as w' = 2 w - 1) at the phase
    // p = floor(n 2^32 / N), then
    // p advances by 2^32 / N (quotient and Bresenham remainder, set at
    // configure): the same integers on every machine, no division per tick.
    // rem + r stays below 2^32: both are < N, and for N > 2^31 r = 2^32 - N.
    constexpr int32_t ramp_shape() {
        const uint32_t p = ramp_phase_;
        ramp_phase_ += ramp_q_;
        ramp_rem_ += ramp_r_;
        if (ramp_rem_ >= cfg_.period_samples) {
            ramp_rem_ -= cfg_.period_samples;
            ++ramp_phase_;
        }
        // As w' = 2 w - 1 (see configure()).
        switch (cfg_.signal) {
            case ExcitationSignal::kStep: return p >= 0x80000000u ? Q31::kMaxRaw : -Q31::kMaxRaw;
            case ExcitationSignal::kTriangle: {
                const int64_t t = p < 0x80000000u ? p : ~p;  // w in [0, 2^31 - 1]
                return static_cast<int32_t>(2 * t - Q31::kMaxRaw);
            }
            default: {
                // 1 - cos -> w' = -cos, cos = sin(p + a quarter).
                const int32_t c = sine_q31(p + 0x40000000u);
                return c <= -Q31::kMaxRaw ? Q31::kMaxRaw : -c;
            }
        }
    }

    // Fibonacci LFSR: the new bit is the XOR of the tapped bits, shifted in
    // at the bottom; it is also the output.
    constexpr uint32_t next_bit() {
        const uint32_t fb = static_cast<uint32_t>(std::popcount(lfsr_ & lfsr_mask_)) & 1u;
        lfsr_ = ((lfsr_ << 1) | fb) & ((1u << cfg_.prbs_order) - 1u);
        return fb;
    }

    // One period, line by line into table_: line k's phase at sample n is
    // floor(k n 2^32 / N) (exact, carried from sample to sample by a
    // Bresenham remainder: no division in the inner loop) minus its
    // Schroeder phase j (j + 1) / (2 K) cycles; each cosine from the sine
    // table is added shifted down by s bits, rounded, with 2^s > K so the sum
    // cannot overflow 32 bits (integer arithmetic: the same bits everywhere).
    // Then the period is normalised to a peak of 2^31 - 1 by one IEEE double
    // division per sample. The shifted terms keep 31 - s bits each: for
    // K = 4000 the rounding is ~1e-5 of a line's amplitude, spread over the
    // period (deterministic, so it is part of d, which is what is recorded).
    constexpr void tabulate_multisine() {
        const uint32_t N = cfg_.period_samples, k1 = cfg_.first_bin, K = cfg_.last_bin - k1 + 1u;
        const int shift = static_cast<int>(std::bit_width(K));
        const int32_t half = int32_t{1} << (shift - 1);
        for (uint32_t n = 0; n < N; ++n) table_[n] = 0;
        for (uint32_t j = 0; j < K; ++j) {
            const uint64_t k = k1 + j;
            const uint64_t b = (uint64_t{j} * (j + 1u)) % (2u * uint64_t{K});
            const uint32_t schroeder = static_cast<uint32_t>((b << 32) / (2u * uint64_t{K}));
            const uint64_t step = (k << 32);  // k 2^32 / N per sample: quotient and remainder
            const uint32_t q = static_cast<uint32_t>(step / N), r = static_cast<uint32_t>(step % N);
            uint32_t phase = 0, rem = 0;
            for (uint32_t n = 0; n < N; ++n) {
                const int32_t c = sine_q31(phase - schroeder + 0x40000000u);  // + a quarter: cos
                table_[n] += static_cast<int32_t>((int64_t{c} + half) >> shift);
                phase += q;
                rem += r;
                if (rem >= N) {
                    rem -= N;
                    ++phase;
                }
            }
        }
        int32_t peak = 1;
        for (uint32_t n = 0; n < N; ++n) {
            const int32_t m = table_[n] < 0 ? -table_[n] : table_[n];
            if (m > peak) peak = m;
        }
        const double scale = 2147483647.0 / static_cast<double>(peak);
        for (uint32_t n = 0; n < N; ++n)
            table_[n] = Q31::from_double(static_cast<double>(table_[n]) * scale * 0x1p-31).raw();
    }

    SignalScale scale_{};
    ExcitationConfig cfg_{};
    bool configured_ = false;
    float amp_f_ = 0.0f, off_f_ = 0.0f;
    int32_t rest_w_ = 0;  // the shape's value at the offset, where d rests when done
    Q31 amp_q_{}, off_q_{};
    std::array<int32_t, TableCapacity> table_{};
    double sweep_ratio_ = 1.0, sweep_inc0_ = 0.0;
    uint32_t lfsr_mask_ = 0;
    uint32_t ramp_q_ = 0, ramp_r_ = 0;  // 2^32 / N per sample

    // State.
    uint32_t n_ = 0;
    uint32_t periods_done_ = 0;
    bool done_ = false;
    uint64_t sweep_phase_ = 0;  // 2^64 = one cycle
    double sweep_inc_ = 0.0;
    uint32_t lfsr_ = 1, hold_n_ = 0, bit_ = 1;
    uint32_t ramp_phase_ = 0, ramp_rem_ = 0;
};

}  // namespace piezoloop
