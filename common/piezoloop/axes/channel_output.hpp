// The actuator channels of a multi-axis board, the last stage before the
// DACs: the output (decoupling) matrix, then each channel's hard limits and
// slew, applied by an OutputLimiter (limits.hpp) whose configured range and
// slew are the channel's hard limits.
//
//   c = M u_axis;  u_channel_i = limiter_i(c_i)  -> DAC channel i
//
// Channel i's voltage scale is axis i's. The axes' own limiters act before
// the matrix (their clamps feed their anti-windup); the channel limiters
// bound what reaches each piezo whatever the matrix mixes: no command, huge
// or not, gives a channel output outside its hard range or a step above its
// hard slew / rate.
//
// Skipped stage: with the identity matrix, and every axis's hard limits
// within its channel's (range inside, hard slew not above), the channel
// limiter could change nothing the axis limiter let through, so the stage
// is skipped and the channel outputs are the axis outputs, bit for bit. A
// change to a mixing matrix starts the limiters from the outputs of the tick
// before (no jump); a change back to the identity keeps the stage running
// until every channel has reached its axis's output, then skips it.
#pragma once

#include <array>
#include <cstddef>
#include <cstdint>
#include <utility>

#include "piezoloop/axes/axis_matrix.hpp"
#include "piezoloop/limits.hpp"
#include "piezoloop/sample.hpp"
#include "piezoloop/status.hpp"

namespace piezoloop {

template <class T, int N>
class ChannelOutput {
    static_assert(N >= 1 && N <= kMaxAxes, "ChannelOutput<N>: 1 to 3 channels");

public:
    // channel_hard: each DAC channel's hard limits (V); rate_Hz: the loop
    // rate; voltage: channel i's V <-> Q31 scale (axis i's); axis_hard: the
    // axes' limiters' hard limits (for the skip rule above). A channel whose
    // hard limits are invalid outputs zero (OutputLimiter's rule) and
    // hard_status() names it.
    ChannelOutput(const std::array<HardLimits, N>& channel_hard, float rate_Hz,
                  const std::array<SignalScale, N>& voltage, const std::array<HardLimits, N>& axis_hard)
        : voltage_(voltage),
          limiters_(make_limiters(channel_hard, rate_Hz, voltage, std::make_index_sequence<N>{})) {
        covers_ = true;
        for (int i = 0; i < N; ++i) {
            OutputLimiter<T>& l = limiters_[i];
            Status s = l.hard_status();
            if (s.ok()) {
                const HardLimits& h = channel_hard[i];
                s = l.configure(LimitsConfig{h.u_min_V, h.u_max_V, h.slew_max_V_per_s, 0.0f});
            }
            if (!s.ok() && hard_status_.ok()) {
                s.index = i;
                hard_status_ = in_group("channels", s);
            }
            const HardLimits& a = axis_hard[i];
            const HardLimits& h = channel_hard[i];
            covers_ = covers_ && s.ok() && a.u_min_V >= h.u_min_V && a.u_max_V <= h.u_max_V &&
                      a.slew_max_V_per_s <= h.slew_max_V_per_s;
            out_[i] = l.output();
        }
        skippable_ = covers_;
        on_ = !covers_;
    }

    // The channels' hard limits as accepted (index: the channel).
    Status hard_status() const { return hard_status_; }

    // Validates m (group "axes", field "output_matrix...") and prepares its
    // applied form into `out`; on error `out` is untouched. Main loop.
    Status prepare(const AxisMatrix<N>& m, AxisTransform<T, N>& out) const {
        if (const Status s = validate_output_matrix(m); !s.ok()) return s;
        AxisTransform<T, N> t;
        const std::array<float, N> no_offset{};
        if (const Status s = t.configure(m, no_offset, voltage_, voltage_, axes_detail::kOutputMatrixName); !s.ok())
            return in_group(kAxesGroup, s);
        out = t;
        return ok_status();
    }

    // A prepared matrix, from the next apply() on (a tick boundary).
    void set_matrix(const AxisTransform<T, N>& t) {
        matrix_ = t;
        skippable_ = t.bypassed() && covers_;
        if (!skippable_ && !on_) {
            // The limiters carry on from what the DACs hold.
            for (int i = 0; i < N; ++i) limiters_[i].preset_output(out_[i]);
            on_ = true;
        }
    }

    // One tick: axis commands in, channel commands (DAC values) out.
    const std::array<T, N>& apply(const std::array<T, N>& u_axis) {
        if (!on_) {
            out_ = u_axis;
            return out_;
        }
        std::array<T, N> c{};
        matrix_.apply(u_axis, c);
        bool caught_up = skippable_;
        for (int i = 0; i < N; ++i) {
            out_[i] = limiters_[i].apply(c[i]);
            caught_up = caught_up && out_[i] == u_axis[i];
        }
        if (caught_up) on_ = false;
        return out_;
    }

    // Whether the stage runs (false: skipped, outputs = axis commands).
    bool active() const { return on_; }
    const std::array<T, N>& output() const { return out_; }
    const AxisTransform<T, N>& matrix() const { return matrix_; }
    const OutputLimiter<T>& limiter(int channel) const { return limiters_[channel]; }
    // Samples each channel's limiter clamped to its hard range, and
    // slew-limited (saturating counters; zero while the stage is skipped).
    uint32_t clamped_samples(int channel) const { return limiters_[channel].clamped_samples(); }
    uint32_t slew_limited_samples(int channel) const { return limiters_[channel].slew_limited_samples(); }
    void reset_counters() {
        for (auto& l : limiters_) l.reset_counters();
    }
    // A channel limiter latches a trip only on a non-finite command (float:
    // an overflow of the matrix; the axes' limiters keep their outputs within
    // +-1e6 V, so not from a pipeline); this releases it.
    void clear_trips() {
        for (auto& l : limiters_) (void)l.clear_trip();
    }

private:
    template <std::size_t... I>
    static std::array<OutputLimiter<T>, N> make_limiters(const std::array<HardLimits, N>& hard, float rate_Hz,
                                                         const std::array<SignalScale, N>& voltage,
                                                         std::index_sequence<I...>) {
        return {OutputLimiter<T>(hard[I], rate_Hz, voltage[I])...};
    }

    std::array<SignalScale, N> voltage_;
    std::array<OutputLimiter<T>, N> limiters_;
    AxisTransform<T, N> matrix_{};  // identity
    Status hard_status_{};
    bool covers_ = false;     // every axis's hard limits within its channel's
    bool skippable_ = false;  // identity matrix and covers_
    bool on_ = true;          // the stage runs
    std::array<T, N> out_{};  // the last channel commands
};

}  // namespace piezoloop
