// Fixed-capacity delay line (ring buffer) for the repetitive controller: it
// holds the last Capacity samples so a period of N <= Capacity samples can be
// read back without any allocation in the loop.
#pragma once

#include <array>
#include <cstdint>

namespace piezoloop {

template <class T, int Capacity>
class DelayLine {
    // A power of two makes the wrap a mask instead of a division.
    static_assert(Capacity > 0 && (Capacity & (Capacity - 1)) == 0, "Capacity must be a power of two");

public:
    static constexpr int capacity() { return Capacity; }

    void reset() {
        buffer_.fill(T{});
        head_ = 0;
    }
    void push(T x) {
        buffer_[head_] = x;
        head_ = (head_ + 1u) & kMask;
    }
    // The sample pushed `delay` pushes ago: past(1) is the latest one.
    // delay must be in [1, Capacity].
    T past(int delay) const { return buffer_[(head_ - static_cast<uint32_t>(delay)) & kMask]; }

private:
    static constexpr uint32_t kMask = static_cast<uint32_t>(Capacity) - 1u;
    uint32_t head_ = 0;  // before the buffer: at a small offset from the line's address
    std::array<T, Capacity> buffer_{};
};

}  // namespace piezoloop
