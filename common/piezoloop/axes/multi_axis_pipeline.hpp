// Two or three coupled axes on one board (XY, XYZ stages): N Pipelines, one
// per axis, between an input matrix and the actuator channels.
//
//   begin_tick(): matrices requested by the main loop are taken over, then
//                 every axis's begin_tick() (reading-independent work)
//   output(readings[N]):
//     y = M_in readings + offset_um    (axis_matrix.hpp; skipped: identity)
//     u_axis_i = axis_i.output(y_i)    each axis's own feedforward, feedback
//                                      and anti-windup, RC, pre-filter, wave,
//                                      excitation and limiter, unchanged
//     u_channel = channel limits(M_out u_axis)   (channel_output.hpp)
//                                      -> the DACs
//   end_tick():   the board's recorder, then every axis's end_tick()
//                 (its own recorder, counters)
// tick(readings) runs the three in order. Reading j is sensor j's, in axis
// j's position scale (float: µm); channel i's command is in axis i's voltage
// scale (float: V).
//
// Each axis's limiter still acts on its own command, so its anti-windup
// sees its clamps; the channel limiters after the output matrix bound what
// reaches each piezo. A channel clamp is not fed back to the axes'
// anti-windup: the axes' limits are to be set so that, through the output
// matrix, they keep the channels inside their ranges, leaving the channel
// limits as the protection they are.
//
// With identity matrices (the input's offsets zero) and the axes' hard
// limits within their channels', both matrix stages are skipped, so every
// axis computes exactly what a Pipeline on its own computes, bit for bit: a
// single-axis MultiAxisPipeline is today's Pipeline.
//
// The board's recorder (recorder()) records any signal of any axis: its
// signal index i is signal i % kSignalCount of axis i / kSignalCount, at the
// tick index of axis 0 (every axis counts the same ticks); index
// kBoardSyncSignal (and any index past the axes' signals) is the sync word
// set_sync() gave the tick (a scan's events). Each axis's own recorder
// records that axis's signals, as a Pipeline's does.
//
// The matrices are limit-critical: set_input_matrix and set_output_matrix
// validate first (a refused matrix changes nothing) and are refused while
// any axis is armed; an accepted one is taken over at the next tick
// boundary, before any axis can arm on that tick.
#pragma once

#include <array>
#include <atomic>
#include <cstddef>
#include <cstdint>
#include <type_traits>
#include <utility>

#include "piezoloop/axes/axis_matrix.hpp"
#include "piezoloop/axes/channel_output.hpp"
#include "piezoloop/pipeline.hpp"
#include "piezoloop/status.hpp"

namespace piezoloop {

// The board recorder's index of the sync word: after the signals of
// kMaxAxes axes, the same on every board.
inline constexpr uint8_t kBoardSyncSignal = static_cast<uint8_t>(kMaxAxes * kSignalCount);

template <int N>
struct MultiAxisSetup {
    std::array<PipelineSetup, N> axes{};   // every axis at the same rate_Hz
    std::array<HardLimits, N> channels{};  // each DAC channel's hard limits (V)
};

// RecChannels: each axis's own recorder; BoardRecChannels: the board's
// recorder of (axis, signal) channels (several axes' signals at once).
template <class T, int N, int RcCapacity = 1024, std::size_t RecChannels = 4, std::size_t RecCapacity = 1024,
          std::size_t ExcCapacity = 1024, std::size_t BoardRecChannels = RecChannels>
class MultiAxisPipeline {
    static_assert(N >= 1 && N <= kMaxAxes, "MultiAxisPipeline<N>: 1 to 3 axes");

public:
    using AxisPipeline = Pipeline<T, RcCapacity, RecChannels, RecCapacity, ExcCapacity>;
    using Samples = std::array<T, N>;
    using RecorderType = Recorder<T, BoardRecChannels, RecCapacity, kBoardSyncSignal + 1>;
    using SampleType = T;

    explicit MultiAxisPipeline(const MultiAxisSetup<N>& setup)
        : MultiAxisPipeline(setup, std::make_index_sequence<N>{}) {}

    // The setup as accepted: every axis at axis 0's rate, every channel's
    // hard limits valid. Otherwise the channel stage outputs zero for good
    // (the channels' limiters are built invalid) and this says why.
    Status setup_status() const { return setup_status_; }

    AxisPipeline& axis(int i) { return axes_[i]; }
    const AxisPipeline& axis(int i) const { return axes_[i]; }

    void arm_all() {
        for (auto& a : axes_) a.arm();
    }
    void disarm_all() {
        for (auto& a : axes_) a.disarm();
    }
    bool any_armed() const {
        for (const auto& a : axes_)
            if (a.armed()) return true;
        return false;
    }

    // Main loop. Validated (errors in group "axes", naming the field, e.g.
    // "input_matrix[1][2]" or "input_offset_um[0]"), refused while any axis
    // is armed or a previous input matrix waits to be taken over; taken
    // over at the next tick boundary.
    Status set_input_matrix(const InputMatrix<N>& m) {
        if (const Status s = validate_input_matrix(m); !s.ok()) return s;
        AxisTransform<T, N> t;
        if (const Status s = t.configure(m.gain, m.offset_um, position_, position_, axes_detail::kInputMatrixName);
            !s.ok())
            return in_group(kAxesGroup, s);
        if (const Status s = changeable(input_pending_, axes_detail::kInputMatrixName); !s.ok()) return s;
        input_next_ = t;
        input_config_ = m;
        input_pending_.store(true, std::memory_order_release);
        return ok_status();
    }
    // The same for the output (decoupling) matrix, "output_matrix[i][j]".
    Status set_output_matrix(const AxisMatrix<N>& m) {
        AxisTransform<T, N> t;
        if (const Status s = channels_.prepare(m, t); !s.ok()) return s;
        if (const Status s = changeable(output_pending_, axes_detail::kOutputMatrixName); !s.ok()) return s;
        output_next_ = t;
        output_config_ = m;
        output_pending_.store(true, std::memory_order_release);
        return ok_status();
    }
    bool matrix_pending() const {
        return input_pending_.load(std::memory_order_acquire) || output_pending_.load(std::memory_order_acquire);
    }
    // The last accepted matrices (in effect, or from the next tick).
    const InputMatrix<N>& input_matrix() const { return input_config_; }
    const AxisMatrix<N>& output_matrix() const { return output_config_; }

    // The tick's phases (see the top of the file); a board may run them
    // apart within its interrupt, as it does a Pipeline's.
    void begin_tick() {
        const bool in_pending = input_pending_.load(std::memory_order_relaxed);
        const bool out_pending = output_pending_.load(std::memory_order_relaxed);
        if (in_pending || out_pending) [[unlikely]] {
            std::atomic_thread_fence(std::memory_order_acquire);
            if (in_pending) {
                input_ = input_next_;
                input_pending_.store(false, std::memory_order_release);
            }
            if (out_pending) {
                channels_.set_matrix(output_next_);
                output_pending_.store(false, std::memory_order_release);
            }
        }
        for (auto& a : axes_) a.begin_tick();
    }
    const Samples& output(const Samples& readings) {
        if (input_.bypassed()) {
            for (int i = 0; i < N; ++i) u_axis_[i] = axes_[i].output(readings[i]);
        } else {
            Samples y{};
            input_.apply(readings, y);
            for (int i = 0; i < N; ++i) u_axis_[i] = axes_[i].output(y[i]);
        }
        return channels_.apply(u_axis_);
    }
    // The tick's sync word for the board's recorder (the reading-independent
    // half, before end_tick; it holds until changed). Float records it as
    // its value, Q31 as its raw bits.
    void set_sync(uint32_t word) {
        if constexpr (std::is_same_v<T, float>) sync_ = static_cast<float>(word);
        else sync_ = T::from_raw(static_cast<int32_t>(word));
    }
    void end_tick() {
        recorder_.push_from(axes_[0].tick_count(), [this](uint8_t i) {
            if (i >= N * kSignalCount) return sync_;
            const TickSignals<T>& s = axes_[i / kSignalCount].last();
            T v;
            __builtin_memcpy(&v, reinterpret_cast<const unsigned char*>(&s) + (i % kSignalCount) * sizeof(T),
                             sizeof(T));
            return v;
        });
        for (auto& a : axes_) a.end_tick();
    }
    Samples tick(const Samples& readings) {
        begin_tick();
        const Samples u = output(readings);
        end_tick();
        return u;
    }

    // The board's recorder: (axis, signal) channels (see the top of the file).
    RecorderType& recorder() { return recorder_; }
    const RecorderType& recorder() const { return recorder_; }
    uint32_t tick_count() const { return axes_[0].tick_count(); }
    static constexpr int axis_count() { return N; }

    // The last tick's axis commands (after each axis's limiter) and channel
    // commands (the DAC values). Each axis's position is axis(i).last().y.
    const Samples& axis_commands() const { return u_axis_; }
    const Samples& channel_commands() const { return channels_.output(); }
    // The channel stage, read-only: its matrix changes only through
    // set_output_matrix.
    const ChannelOutput<T, N>& channels() const { return channels_; }
    // Per channel: samples clamped to its hard range, and slew-limited.
    uint32_t channel_clamped_samples(int channel) const { return channels_.clamped_samples(channel); }
    uint32_t channel_slew_limited_samples(int channel) const { return channels_.slew_limited_samples(channel); }
    void reset_channel_counters() { channels_.reset_counters(); }
    // Releases a channel limiter's non-finite trip (see ChannelOutput).
    void clear_channel_trips() { channels_.clear_trips(); }

private:
    template <std::size_t... I>
    MultiAxisPipeline(const MultiAxisSetup<N>& s, std::index_sequence<I...>)
        : axes_{AxisPipeline(s.axes[I])...},
          channels_(s.channels, equal_rates(s) ? s.axes[0].rate_Hz : 0.0f, {s.axes[I].voltage...},
                    {s.axes[I].hard...}),
          position_{s.axes[I].position...} {
        if (!equal_rates(s)) {
            for (int i = 1; i < N; ++i)
                if (!(s.axes[i].rate_Hz == s.axes[0].rate_Hz))
                    setup_status_ = in_group(kAxesGroup, error("rate_Hz", i, "every axis must run at axis 0's rate"));
        } else {
            setup_status_ = channels_.hard_status();
        }
    }
    static bool equal_rates(const MultiAxisSetup<N>& s) {
        for (int i = 1; i < N; ++i)
            if (!(s.axes[i].rate_Hz == s.axes[0].rate_Hz)) return false;
        return true;
    }

    Status changeable(const std::atomic<bool>& pending, const char* name) const {
        if (any_armed()) return in_group(kAxesGroup, error(name, "changes only while every axis is disarmed"));
        if (pending.load(std::memory_order_acquire))
            return in_group(kAxesGroup, error(name, "the previous matrix is not yet taken over; retry after one tick"));
        return ok_status();
    }

    std::array<AxisPipeline, N> axes_;
    RecorderType recorder_{};
    ChannelOutput<T, N> channels_;
    std::array<SignalScale, N> position_;
    Status setup_status_{};
    AxisTransform<T, N> input_{};  // identity
    Samples u_axis_{};
    T sync_{};
    // Main loop -> tick handover (written before the flag is set).
    AxisTransform<T, N> input_next_{}, output_next_{};
    std::atomic<bool> input_pending_{false}, output_pending_{false};
    InputMatrix<N> input_config_{};
    AxisMatrix<N> output_config_ = AxisMatrix<N>::identity();
};

}  // namespace piezoloop
