// SysTick as a free-running timestamp counter and as an instruction
// stopwatch on the QEMU boards (ARMv7-M ARM B3.3: SYST_CSR 0xE000E010,
// SYST_RVR 0xE000E014, SYST_CVR 0xE000E018; a 24-bit down counter).
//
// Under qemu-system-arm -icount shift=0 virtual time advances exactly one
// nanosecond per executed instruction, and SysTick on the processor clock
// (25 MHz on MPS2) decrements once every 40 instructions. Reading CVR twice
// gives the elapsed time to 40 instructions. The stopwatch here does better
// with a vernier:
//   start: spin on CVR until it changes, i.e. start exactly at a count edge
//          (to within one pass of a 3-instruction loop);
//   stop:  read CVR = v, then spin, counting passes k of a 4-instruction
//          loop, until CVR leaves v: that edge lies 40 * (counts since the
//          start edge) instructions after the start, and k * 4 instructions
//          after the stop.
// elapsed = 40 * counts - 4 * k - calibration, resolution 4 instructions
// (the two spin loops' pass lengths; the error is within (-4, +4) and
// averages out over ticks of varying phase). The calibration is the mean of
// measuring an empty region. Each measurement spins up to 2 * 40
// instructions outside the measured region.
#pragma once

#include <cstdint>

namespace piezoloop::bsp::systick {

inline constexpr uintptr_t kCsr = 0xE000E010;
inline constexpr uintptr_t kRvr = 0xE000E014;
inline constexpr uintptr_t kCvr = 0xE000E018;
inline constexpr uint32_t kCsrEnable = 1u << 0;
inline constexpr uint32_t kCsrClkSourceCpu = 1u << 2;  // processor clock, not the reference clock
inline constexpr uint32_t kMask = 0x00FFFFFFu;           // 24-bit counter

inline volatile uint32_t& reg(uintptr_t address) { return *reinterpret_cast<volatile uint32_t*>(address); }

// Free-running on the processor clock, no interrupt.
inline void start_free_running() {
    reg(kCsr) = 0;
    reg(kRvr) = kMask;  // period 2^24 counts: plain modulo arithmetic
    reg(kCvr) = 0;      // any write clears it; the counter reloads
    reg(kCsr) = kCsrEnable | kCsrClkSourceCpu;
}

// Counts up (SysTick counts down).
inline uint32_t up_count() { return kMask - (reg(kCvr) & kMask); }

// Spins until CVR changes; returns the new CVR (the start edge).
__attribute__((always_inline)) inline uint32_t sync_to_edge() {
    const volatile uint32_t* cvr = &reg(kCvr);
    const uint32_t first = *cvr;
    uint32_t now;
    asm volatile(
        "1:\n\t"
        "ldr  %[now], [%[cvr]]\n\t"
        "cmp  %[now], %[first]\n\t"
        "beq  1b\n\t"
        : [now] "=&r"(now)
        : [cvr] "r"(cvr), [first] "r"(first)
        : "cc", "memory");
    return now;
}

struct StopReading {
    uint32_t cvr;     // CVR at the stop
    uint32_t passes;  // passes of the 4-instruction loop until CVR left it
};

__attribute__((always_inline)) inline StopReading read_stop() {
    const volatile uint32_t* cvr = &reg(kCvr);
    uint32_t at_stop, now, passes = 0;
    asm volatile(
        "ldr  %[stop], [%[cvr]]\n\t"
        "1:\n\t"
        "adds %[k], %[k], #1\n\t"
        "ldr  %[now], [%[cvr]]\n\t"
        "cmp  %[now], %[stop]\n\t"
        "beq  1b\n\t"
        : [stop] "=&r"(at_stop), [now] "=&r"(now), [k] "+&r"(passes)
        : [cvr] "r"(cvr)
        : "cc", "memory");
    return {at_stop, passes};
}

inline constexpr uint32_t kInsnPerCount = 40;  // 1 ns per instruction, 25 MHz
inline constexpr uint32_t kStopLoopInsn = 4;

// Instructions from the start edge to the stop, before calibration. The
// counter runs down: the edge after the stop is at count (cvr - 1), which is
// (start - cvr + 1) counts after the start edge.
inline int32_t raw_elapsed(uint32_t start_cvr, StopReading stop) {
    const uint32_t counts = (start_cvr - stop.cvr + 1u) & kMask;
    return static_cast<int32_t>(counts * kInsnPerCount) - static_cast<int32_t>(stop.passes * kStopLoopInsn);
}

}  // namespace piezoloop::bsp::systick
