// Recorder: an oscilloscope for the loop's internal signals.
//
// Every tick the pipeline hands over its whole signal vector (r, y, e, u, ...)
// and the recorder keeps a selection of it as frames
//     Frame { tick, value[Channels] }
// in a fixed ring of Capacity frames (no heap).
//
// - Selection: Config::channels lists the signal indices that make up a frame.
// - Decimation: keep every N-th tick.
// - Trigger: immediate, or a level crossing (rising: previous < level <=
//   current; falling: previous > level >= current) of any signal, evaluated on
//   every tick so a crossing between kept ticks is not missed. The decimation
//   phase restarts at the trigger tick, so frame [pre_trigger] of a record is
//   exactly the trigger tick. The trigger is held off until pre_trigger frames
//   have been recorded since arm(), so a record always has its full history.
// - States: idle -> arm() -> armed (records the pre-trigger history, looks for
//   the trigger) -> triggered (records) -> done (single shot: after `length`
//   frames in total). stop() returns to idle from any state.
// - Modes: single shot (one record of `length` frames, which always fits) or
//   continuous (a stream that a reader drains with read()).
// - Overrun: when the reader is too slow the writer drops the *newest* frame
//   and counts it in overruns(). Dropping the newest keeps what the reader
//   already sees consistent, and the gap is visible in the tick indices too;
//   nothing is ever lost silently.
//
// Concurrency: push() (the tick, e.g. an interrupt) and read() / available() /
// overruns() / state() (one reader, e.g. the link service) may run
// concurrently: single producer, single consumer, lock-free, each index has
// exactly one writer, published with release/acquire (GCC __atomic builtins,
// which need no header and are plain loads/stores plus barriers on
// Cortex-M). configure(), arm() and stop() belong to the reader's context and
// must not run concurrently with push(): call them with the tick masked, or
// let the tick apply them at a tick boundary.
//
// Sequence numbers are uint32 and start at 2^32 - 2^16 (the trick of Linux's
// INITIAL_JIFFIES): every run crosses their wrap after 65536 frames, so wrap
// bugs show up in the tests instead of after 12 hours. Only differences of
// sequence numbers are ever used. Tick indices are the caller's uint32 tick
// counter (it wraps after 11.9 h at 100 kHz; readers unwrap by difference).
#pragma once

#include <array>
#include <bit>
#include <cstddef>
#include <cstdint>
#include <span>
#include <type_traits>

#include "piezoloop/q31.hpp"
#include "piezoloop/sample.hpp"
#include "piezoloop/status.hpp"

namespace piezoloop {

// The signals the control pipeline offers to the recorder, by index.
enum class SignalId : uint8_t {
    kR = 0,  // reference (µm)
    kY,      // measured displacement
    kE,      // e = r - y
    kU,      // command to the amplifier after limits (V)
    kUff,    // feedforward (inverse hysteresis)
    kUfb,    // feedback
    kUrc,    // repetitive-control plug-in contribution
    kD,      // excitation d (excitation.hpp): V at the command, µm at the reference; 0 when none runs
    kCount
};
inline constexpr std::size_t kSignalCount = static_cast<std::size_t>(SignalId::kCount);

constexpr uint8_t signal_index(SignalId s) { return static_cast<uint8_t>(s); }
constexpr const char* signal_name(SignalId s) {
    switch (s) {
        case SignalId::kR: return "r";
        case SignalId::kY: return "y";
        case SignalId::kE: return "e";
        case SignalId::kU: return "u";
        case SignalId::kUff: return "u_ff";
        case SignalId::kUfb: return "u_fb";
        case SignalId::kUrc: return "u_rc";
        case SignalId::kD: return "d";
        case SignalId::kCount: break;
    }
    return "?";
}

enum class TriggerMode : uint8_t { kImmediate, kRising, kFalling };
enum class RecordMode : uint8_t { kSingleShot, kContinuous };
enum class RecorderState : uint8_t { kIdle, kArmed, kTriggered, kDone };

template <std::size_t Channels>
struct RecorderConfig {
    std::array<uint8_t, Channels> channels{};  // signal indices, in frame order
    uint32_t decimation = 1;                   // keep every N-th tick, N >= 1
    RecordMode mode = RecordMode::kSingleShot;
    TriggerMode trigger = TriggerMode::kImmediate;
    uint8_t trigger_signal = 0;   // signal index watched (need not be recorded)
    float trigger_level = 0.0f;   // physical units of that signal
    SignalScale trigger_scale{};  // its Q31 scale (ignored for float)
    uint32_t pre_trigger = 0;     // frames before the trigger frame (0 with kImmediate)
    uint32_t length = 0;          // single shot: frames in total incl. pre-trigger, 0 = Capacity
};

template <class S, std::size_t Channels, std::size_t Capacity, std::size_t Signals = kSignalCount>
class Recorder {
    static_assert(is_sample_type_v<S>, "Recorder<S,...>: S is float or Q31");
    static_assert(Channels >= 1, "at least one channel");
    static_assert(Signals >= 1 && Signals <= 256, "signal indices are uint8_t");
    static_assert(Capacity >= 2 && Capacity <= (std::size_t{1} << 30) && std::has_single_bit(Capacity),
                  "Capacity must be a power of two (sequence numbers index the ring by mask)");

public:
    struct Frame {
        uint32_t tick = 0;
        std::array<S, Channels> value{};
    };
    using Config = RecorderConfig<Channels>;
    using SignalVector = std::array<S, Signals>;
    static constexpr std::size_t kChannels = Channels;

    static constexpr uint32_t kSeqStart = 0u - (1u << 16);

    // Validates c and swaps it in; the recorder becomes idle and unread frames
    // are discarded. On error nothing changes. Reader context.
    Status configure(const Config& c) {
        if (const Status s = validate(c); !s.ok()) return s;
        uint32_t length = 0;
        if (c.mode == RecordMode::kSingleShot) length = c.length == 0 ? static_cast<uint32_t>(Capacity) : c.length;
        S level{};
        if constexpr (std::is_same_v<S, float>) {
            level = c.trigger_level;
        } else {
            level = c.trigger_scale.template to_sample<Q31>(c.trigger_level);
        }

        cfg_ = c;
        streaming_ = c.mode == RecordMode::kContinuous && c.decimation == 1;
        length_ = length;
        level_ = level;
        configured_ = true;
        set_state(RecorderState::kIdle);
        discard();
        return ok_status();
    }

    // The checks of configure(), touching nothing (a whole parameter set is
    // checked before any of it is applied).
    static Status validate(const Config& c) {
        for (const uint8_t ch : c.channels) {
            if (ch >= Signals) return error("channels", "signal index must be < the number of signals");
        }
        if (c.decimation < 1) return error("decimation", "must be >= 1");
        if (c.trigger_signal >= Signals) return error("trigger_signal", "must be < the number of signals");
        if (c.trigger != TriggerMode::kImmediate && c.trigger != TriggerMode::kRising &&
            c.trigger != TriggerMode::kFalling)
            return error("trigger", "unknown trigger mode");
        if ((std::bit_cast<uint32_t>(c.trigger_level) & 0x7f800000u) == 0x7f800000u)
            return error("trigger_level", "must be finite");
        if (c.trigger == TriggerMode::kImmediate && c.pre_trigger != 0)
            return error("pre_trigger", "must be 0 with an immediate trigger");
        uint32_t length = 0;
        if (c.mode == RecordMode::kSingleShot) {
            length = c.length == 0 ? static_cast<uint32_t>(Capacity) : c.length;
            if (length > Capacity) return error("length", "must be <= Capacity (0 = Capacity)");
            if (c.pre_trigger >= length) return error("pre_trigger", "must be < length");
        } else if (c.mode == RecordMode::kContinuous) {
            if (c.pre_trigger >= Capacity) return error("pre_trigger", "must be < Capacity");
        } else {
            return error("mode", "unknown record mode");
        }
        if constexpr (!std::is_same_v<S, float>) {
            const float fs = c.trigger_scale.full_scale;
            if (!(fs > 0.0f) || (std::bit_cast<uint32_t>(fs) & 0x7f800000u) == 0x7f800000u)
                return error("trigger_scale", "full scale must be > 0 and finite");
        }
        return ok_status();
    }

    // Start a record (discarding frames not yet read). Reader context.
    // Returns false if no configuration has been accepted.
    bool arm() {
        if (!configured_) return false;
        discard();
        set_state(RecorderState::kArmed);
        return true;
    }

    // Back to idle; frames already recorded stay readable. Reader context.
    void stop() { set_state(RecorderState::kIdle); }

    // The tick: offer all signals. Bounded time (one frame copy), never fails.
    void push(uint32_t tick, const SignalVector& signals) {
        push_from(tick, [&signals](uint8_t i) { return signals[i]; });
    }

    // The same, reading signal i as `signal(i)` (S signal(uint8_t i), i <
    // Signals): lets the pipeline offer its signals where they already are
    // instead of copying them into a SignalVector every tick.
    // Inlined into the tick up to the streaming case; the other states
    // take a call.
    template <class Source>
    [[gnu::always_inline]] void push_from(uint32_t tick, const Source& signal) {
        // configure(), arm() and stop() never run concurrently with push, so
        // the writer's own view of the state needs no barrier.
        const RecorderState st = static_cast<RecorderState>(__atomic_load_n(&state_, __ATOMIC_RELAXED));
        // Fast path, the streaming case (triggered, continuous, every tick):
        // the general path below would keep dec_count_ at 0 and never finish.
        if (st == RecorderState::kTriggered && streaming_) {
            append(tick, signal);
            return;
        }
        if (st != RecorderState::kArmed && st != RecorderState::kTriggered) return;
        push_record(tick, st, signal);
    }

    // Reader: copies up to out.size() frames, oldest first, and removes them.
    std::size_t read(std::span<Frame> out) {
        const uint32_t h = __atomic_load_n(&head_, __ATOMIC_ACQUIRE);
        const uint32_t s = __atomic_load_n(&start_, __ATOMIC_ACQUIRE);
        uint32_t t = tail_;
        if (static_cast<int32_t>(s - t) > 0) t = s;
        std::size_t n = h - t;
        if (n > out.size()) n = out.size();
        for (std::size_t i = 0; i < n; ++i) out[i] = frames_[(t + static_cast<uint32_t>(i)) & kMask];
        __atomic_store_n(&tail_, t + static_cast<uint32_t>(n), __ATOMIC_RELEASE);
        return n;
    }

    // Reader: frames ready to read.
    std::size_t available() const {
        const uint32_t h = __atomic_load_n(&head_, __ATOMIC_ACQUIRE);
        const uint32_t s = __atomic_load_n(&start_, __ATOMIC_ACQUIRE);
        uint32_t t = tail_;
        if (static_cast<int32_t>(s - t) > 0) t = s;
        return h - t;
    }

    // Frames dropped since arm()/configure() because the reader was too slow (saturating).
    uint32_t overruns() const { return __atomic_load_n(&overruns_, __ATOMIC_RELAXED); }
    RecorderState state() const {
        return static_cast<RecorderState>(__atomic_load_n(&state_, __ATOMIC_ACQUIRE));
    }
    // Tick of the trigger frame of the current record (valid once triggered).
    uint32_t trigger_tick() const { return trigger_tick_; }
    bool configured() const { return configured_; }
    const Config& config() const { return cfg_; }
    static constexpr std::size_t capacity() { return Capacity; }
    static constexpr std::size_t channels() { return Channels; }

private:
    static constexpr uint32_t kMask = static_cast<uint32_t>(Capacity - 1);

    void set_state(RecorderState s) { __atomic_store_n(&state_, static_cast<uint8_t>(s), __ATOMIC_RELEASE); }

    // push_from() in the armed and the other triggered states: trigger,
    // decimation, pre-trigger history, single shot.
    template <class Source>
    [[gnu::noinline]] void push_record(uint32_t tick, RecorderState st, const Source& signal) {
        bool fire = false;
        if (st == RecorderState::kArmed) {
            if (cfg_.trigger == TriggerMode::kImmediate) {
                fire = true;
            } else {
                const S x = signal(cfg_.trigger_signal);
                if (have_prev_ && pre_count_ >= cfg_.pre_trigger) {
                    fire = cfg_.trigger == TriggerMode::kRising ? (prev_ < level_ && !(x < level_))
                                                                 : (level_ < prev_ && !(level_ < x));
                }
                prev_ = x;
                have_prev_ = true;
            }
            if (fire) dec_count_ = 0;  // the trigger tick is a kept tick
        }

        const bool keep = dec_count_ == 0;
        dec_count_ = dec_count_ + 1 >= cfg_.decimation ? 0 : dec_count_ + 1;
        if (!keep) return;

        if (st == RecorderState::kArmed && !fire) {
            // Pre-trigger history: nothing is published, the ring is
            // overwritten freely. Keep wr_ within 2*Capacity of the arm point
            // (same slots, seq - Capacity) so the start of the record never
            // runs far ahead of the reader's index.
            write_frame(tick, signal);
            if (pre_count_ < cfg_.pre_trigger) ++pre_count_;
            if (wr_ - base_ >= 2 * Capacity) wr_ -= static_cast<uint32_t>(Capacity);
            return;
        }

        if (fire) {
            // The record starts pre_count_ (<= pre_trigger < Capacity) frames
            // back; those slots still hold the newest history frames.
            const uint32_t start = wr_ - pre_count_;
            trigger_tick_ = tick;
            write_frame(tick, signal);
            __atomic_store_n(&start_, start, __ATOMIC_RELEASE);
            __atomic_store_n(&head_, wr_, __ATOMIC_RELEASE);  // publishes start_ too
            set_state(finished(start) ? RecorderState::kDone : RecorderState::kTriggered);
            return;
        }

        // Triggered: append unless the reader has not made room.
        if (append(tick, signal) && finished(start_)) set_state(RecorderState::kDone);
    }

    // All values are read before the frame is written (unrolled for the
    // channel count): a frame store could alias the byte-sized channel
    // table, which would make the compiler reload it after every channel.
    template <class Source>
    void write_frame(uint32_t tick, const Source& signal) {
        S v[Channels];
#pragma GCC unroll 16
        for (std::size_t c = 0; c < Channels; ++c) v[c] = signal(cfg_.channels[c]);
        const uint32_t w = wr_;
        Frame& f = frames_[w & kMask];
        f.tick = tick;
#pragma GCC unroll 16
        for (std::size_t c = 0; c < Channels; ++c) f.value[c] = v[c];
        wr_ = w + 1u;
    }

    // Triggered: one frame, published, unless the reader has not made room
    // (then the newest frame is dropped and counted). True if appended.
    template <class Source>
    bool append(uint32_t tick, const Source& signal) {
        uint32_t t = __atomic_load_n(&tail_, __ATOMIC_ACQUIRE);
        const uint32_t start = start_;
        if (static_cast<int32_t>(start - t) > 0) t = start;
        if (wr_ - t >= Capacity) {
            const uint32_t o = __atomic_load_n(&overruns_, __ATOMIC_RELAXED);
            if (o != 0xffffffffu) __atomic_store_n(&overruns_, o + 1u, __ATOMIC_RELAXED);
            return false;
        }
        write_frame(tick, signal);
        __atomic_store_n(&head_, wr_, __ATOMIC_RELEASE);
        return true;
    }

    bool finished(uint32_t start) const {
        return cfg_.mode == RecordMode::kSingleShot && wr_ - start >= length_;
    }

    // Control context only (not concurrent with push or read).
    void discard() {
        base_ = wr_;
        start_ = wr_;
        head_ = wr_;
        tail_ = wr_;
        overruns_ = 0;
        dec_count_ = 0;
        pre_count_ = 0;
        have_prev_ = false;
        trigger_tick_ = 0;
    }

    Config cfg_{};
    uint32_t length_ = 0;
    S level_{};
    bool configured_ = false;
    bool streaming_ = false;  // continuous and decimation 1: push's fast path

    // Sequence numbers. Writer: wr_ (private), head_, start_. Reader: tail_.
    uint32_t wr_ = kSeqStart;
    uint32_t head_ = kSeqStart;
    uint32_t start_ = kSeqStart;
    uint32_t tail_ = kSeqStart;
    uint32_t base_ = kSeqStart;  // wr_ at arm()
    uint32_t overruns_ = 0;
    uint8_t state_ = static_cast<uint8_t>(RecorderState::kIdle);

    // Writer state.
    uint32_t dec_count_ = 0;
    uint32_t pre_count_ = 0;  // history frames since arm(), saturates at pre_trigger
    bool have_prev_ = false;
    S prev_{};
    uint32_t trigger_tick_ = 0;

    // Last: every other member stays within a load's immediate offset of
    // the recorder's address (the tick's push reads them all).
    std::array<Frame, Capacity> frames_{};
};

}  // namespace piezoloop
