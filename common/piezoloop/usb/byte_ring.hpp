// Single-producer single-consumer byte ring between an interrupt (the USB
// driver moving bulk packets) and the main loop (the link service): no
// locks, no allocation. Capacity is a power of two; the indices are free-
// running uint32 counters (only their difference is used, so they may
// wrap), each written by one side only and published with release/acquire
// (GCC __atomic builtins: plain loads/stores plus barriers on Cortex-M).
#pragma once

#include <array>
#include <cstddef>
#include <cstdint>

namespace piezoloop::usb {

template <std::size_t Capacity>
class ByteRing {
    static_assert(Capacity >= 2 && (Capacity & (Capacity - 1)) == 0 && Capacity <= (std::size_t{1} << 31),
                  "Capacity must be a power of two");

public:
    // start: initial value of both counters (tests start near 2^32 to
    // cross the counters' wrap early).
    explicit constexpr ByteRing(uint32_t start = 0) : head_(start), tail_(start) {}

    static constexpr std::size_t capacity() { return Capacity; }

    // Producer: bytes that fit now.
    std::size_t free_space() const { return Capacity - used(load(tail_), head_); }
    // Producer: appends up to n bytes, returns how many it took (all or
    // what fits; a packet that must not be split checks free_space first).
    std::size_t write(const uint8_t* data, std::size_t n) {
        const uint32_t head = head_;
        const std::size_t room = Capacity - used(load(tail_), head);
        if (n > room) n = room;
        for (std::size_t i = 0; i < n; ++i) buffer_[(head + static_cast<uint32_t>(i)) & kMask] = data[i];
        __atomic_store_n(&head_, head + static_cast<uint32_t>(n), __ATOMIC_RELEASE);
        return n;
    }

    // Consumer: bytes ready.
    std::size_t available() const { return used(tail_, load(head_)); }
    // Consumer: removes up to n bytes into out, returns how many.
    std::size_t read(uint8_t* out, std::size_t n) {
        const uint32_t tail = tail_;
        const std::size_t ready = used(tail, load(head_));
        if (n > ready) n = ready;
        for (std::size_t i = 0; i < n; ++i) out[i] = buffer_[(tail + static_cast<uint32_t>(i)) & kMask];
        __atomic_store_n(&tail_, tail + static_cast<uint32_t>(n), __ATOMIC_RELEASE);
        return n;
    }

private:
    static constexpr uint32_t kMask = static_cast<uint32_t>(Capacity - 1);
    static uint32_t load(const uint32_t& x) { return __atomic_load_n(&x, __ATOMIC_ACQUIRE); }
    static std::size_t used(uint32_t tail, uint32_t head) { return static_cast<std::size_t>(head - tail); }

    std::array<uint8_t, Capacity> buffer_{};
    uint32_t head_;  // written by the producer
    uint32_t tail_;  // written by the consumer
};

}  // namespace piezoloop::usb
