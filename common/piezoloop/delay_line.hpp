// Fixed-capacity delay line (ring buffer) for the repetitive controller: it
// holds the last Capacity samples so a period of N <= Capacity samples can be
// read back without any allocation in the loop.
//
// Only the last `window` samples are ever read (past(delay) with delay <=
// window; the repetitive controller's window is its period N). Resetting
// and copying touch those alone, so a reconfiguration in the tick costs N
// stores, not Capacity: a board's line can be long (a scan's line period)
// while the period in use is short. Two lines are interchangeable wherever
// past() is called within the window.
#pragma once

#include <algorithm>
#include <array>
#include <cstdint>

namespace piezoloop {

template <class T, int Capacity>
class DelayLine {
    // A power of two makes the wrap a mask instead of a division.
    static_assert(Capacity > 0 && (Capacity & (Capacity - 1)) == 0, "Capacity must be a power of two");

public:
    static constexpr int capacity() { return Capacity; }

    DelayLine() = default;
    constexpr explicit DelayLine(int window) : window_(clamp_window(window)) {}
    DelayLine(const DelayLine&) = default;
    // Copies the head and the window's samples (the rest is never read).
    DelayLine& operator=(const DelayLine& o) {
        if (this == &o) return *this;
        head_ = o.head_;
        window_ = o.window_;
        const Span s = window_span();
        std::copy(o.buffer_.begin() + s.wrapped_from, o.buffer_.end(), buffer_.begin() + s.wrapped_from);
        std::copy(o.buffer_.begin() + s.from, o.buffer_.begin() + head_, buffer_.begin() + s.from);
        return *this;
    }

    // How many of the latest samples past() reads: [1, Capacity]. Takes
    // effect with the next reset().
    constexpr void set_window(int window) { window_ = clamp_window(window); }

    // Zero history within the window.
    void reset() {
        head_ = 0;
        const Span s = window_span();
        std::fill(buffer_.begin() + s.wrapped_from, buffer_.end(), T{});
    }
    void push(T x) {
        buffer_[head_] = x;
        head_ = (head_ + 1u) & kMask;
    }
    // The sample pushed `delay` pushes ago: past(1) is the latest one.
    // delay must be in [1, window].
    T past(int delay) const { return buffer_[(head_ - static_cast<uint32_t>(delay)) & kMask]; }

private:
    static constexpr uint32_t kMask = static_cast<uint32_t>(Capacity) - 1u;
    static constexpr uint32_t clamp_window(int window) {
        return window < 1 ? 1u : window > Capacity ? static_cast<uint32_t>(Capacity) : static_cast<uint32_t>(window);
    }
    // The window's slots, head_ - window_ .. head_ - 1 modulo Capacity, as at
    // most two runs: [from, head_) and, where it wraps, [wrapped_from, Capacity).
    struct Span {
        uint32_t from, wrapped_from;
    };
    Span window_span() const {
        if (head_ >= window_) return {head_ - window_, static_cast<uint32_t>(Capacity)};
        return {0u, static_cast<uint32_t>(Capacity) - (window_ - head_)};
    }
    uint32_t head_ = 0;  // before the buffer: at a small offset from the line's address
    uint32_t window_ = static_cast<uint32_t>(Capacity);
    std::array<T, Capacity> buffer_{};
};

}  // namespace piezoloop
