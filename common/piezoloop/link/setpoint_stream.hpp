// The setpoint stream of the link: a FIFO of setpoints the host sends in
// numbered blocks (SetpointBlock) and the tick consumes one per tick.
//
// Contexts: start(), push(), stop() and the counters run in the main loop;
// on_tick() in the tick. The main loop writes head_, the tick tail_; both
// are published with acquire/release atomics, so the FIFO needs no lock.
// An empty FIFO while running holds the last setpoint and counts an
// underrun (never silent); a drained stream ends when the FIFO runs empty.
#pragma once

#include <array>
#include <cstddef>
#include <cstdint>

#include "piezoloop/det_math.hpp"
#include "piezoloop/link/messages.hpp"
#include "piezoloop/sample.hpp"
#include "piezoloop/status.hpp"

namespace piezoloop::link {

template <class T, std::size_t Capacity>
class SetpointStream {
    static_assert(Capacity >= 2 && Capacity <= 32768 && (Capacity & (Capacity - 1)) == 0,
                  "setpoint FIFO: power of two, at most 32768");

public:
    static constexpr std::size_t kCapacity = Capacity;

    // Why push() refused a block (kNone: accepted).
    enum class Refusal : uint8_t { kNone, kNotOpen, kSequence, kValue, kNoSpace };

    // ---- main loop ----

    // Opens a new stream: empty FIFO, block sequence and counters from 0. The
    // tick starts consuming once `prefill` setpoints are buffered (0: at
    // once, counting underruns from now on).
    void start(uint16_t prefill) {
        set_state(kIdle);  // stop the tick consuming before the FIFO is reset
        head_ = tail_ = 0;
        next_block_seq_ = 0;
        underruns_ = consumed_ = 0;
        __atomic_store_n(&drain_, false, __ATOMIC_RELEASE);
        prefill_ = prefill;
        set_state(prefill == 0 ? kRunning : kPriming);
    }

    // Drain: consume what is buffered, then end. Otherwise end now.
    void stop(bool drain) {
        if (drain && state() != kIdle) {
            __atomic_store_n(&drain_, true, __ATOMIC_RELEASE);
            if (state() == kPriming) set_state(kRunning);
        } else {
            set_state(kIdle);
        }
    }

    // Appends a block (µm) converted with `position`. On refusal nothing is
    // buffered; `bad_index` names the offending setpoint for kValue.
    Refusal push(const SetpointBlock& m, SignalScale position, int& bad_index) {
        if (state() == kIdle || drain_) return Refusal::kNotOpen;
        if (m.block_seq != next_block_seq_) return Refusal::kSequence;
        for (std::size_t i = 0; i < m.count; ++i) {
            const float x = m.setpoint_um[i];
            if (!is_finite(x) || x < -1.0e6f || x > 1.0e6f) {
                bad_index = static_cast<int>(i);
                return Refusal::kValue;
            }
        }
        if (m.count > free_slots()) return Refusal::kNoSpace;
        uint32_t head = head_;
        for (std::size_t i = 0; i < m.count; ++i) fifo_[(head++) & kMask] = position.to_sample<T>(m.setpoint_um[i]);
        __atomic_store_n(&head_, head, __ATOMIC_RELEASE);
        ++next_block_seq_;
        if (state() == kPriming && Capacity - free_slots() >= prefill_) set_state(kRunning);
        return Refusal::kNone;
    }

    SetpointAck ack() const {
        SetpointAck a;
        a.next_block_seq = next_block_seq_;
        a.free = static_cast<uint16_t>(free_slots());
        a.capacity = static_cast<uint16_t>(Capacity);
        a.underruns = underruns();
        a.consumed = __atomic_load_n(&consumed_, __ATOMIC_RELAXED);
        return a;
    }

    bool open() const { return state() != kIdle; }
    bool draining() const { return __atomic_load_n(&drain_, __ATOMIC_ACQUIRE); }
    uint32_t underruns() const { return __atomic_load_n(&underruns_, __ATOMIC_RELAXED); }
    uint32_t next_block_seq() const { return next_block_seq_; }
    std::size_t free_slots() const { return Capacity - (head_ - __atomic_load_n(&tail_, __ATOMIC_ACQUIRE)); }

    // ---- tick ----

    // The next setpoint, or false when the stream is not running or the FIFO
    // is empty (then the caller's setpoint holds). Bounded time, never fails.
    bool on_tick(T& setpoint) {
        if (state() != kRunning) return false;
        const uint32_t head = __atomic_load_n(&head_, __ATOMIC_ACQUIRE);
        const uint32_t tail = tail_;
        if (head != tail) {
            setpoint = fifo_[tail & kMask];
            __atomic_store_n(&tail_, tail + 1u, __ATOMIC_RELEASE);
            __atomic_store_n(&consumed_, consumed_ + 1u, __ATOMIC_RELAXED);
            return true;
        }
        if (__atomic_load_n(&drain_, __ATOMIC_ACQUIRE)) {
            set_state(kIdle);  // end of a drained stream: the setpoint holds
        } else {
            const uint32_t u = __atomic_load_n(&underruns_, __ATOMIC_RELAXED);
            if (u != 0xffffffffu) __atomic_store_n(&underruns_, u + 1u, __ATOMIC_RELAXED);
        }
        return false;
    }

private:
    enum : uint8_t { kIdle = 0, kPriming = 1, kRunning = 2 };
    static constexpr uint32_t kMask = static_cast<uint32_t>(Capacity - 1);

    uint8_t state() const { return __atomic_load_n(&state_, __ATOMIC_ACQUIRE); }
    void set_state(uint8_t s) { __atomic_store_n(&state_, s, __ATOMIC_RELEASE); }

    std::array<T, Capacity> fifo_{};
    uint32_t head_ = 0;  // main loop
    uint32_t tail_ = 0;  // tick
    uint8_t state_ = kIdle;
    bool drain_ = false;
    uint16_t prefill_ = 0;
    uint32_t next_block_seq_ = 0;
    uint32_t underruns_ = 0;  // tick
    uint32_t consumed_ = 0;   // tick
};

}  // namespace piezoloop::link
