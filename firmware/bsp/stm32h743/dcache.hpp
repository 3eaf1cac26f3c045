// The Cortex-M7's data cache (16 KiB, 4 ways, 32-byte lines on the
// STM32H743). Off after reset and in the single-axis image, whose data all
// lives in DTCM, which is never cached. The three-axis image keeps its axes
// in AXI SRAM (memory.ld) and turns the cache on, so the tick does not pay
// the AXI bus's wait states on every access to them.
//
// Nothing in the firmware moves data by DMA, so the only memory that changes
// behind the cache is the flash sector of the stored parameter set
// (flash_storage.cpp), which invalidates its lines after erasing and
// programming it. Written from the ARMv7-M Architecture Reference Manual
// (cache maintenance by set/way and by address) and the Cortex-M7 TRM.
//
// NOT VERIFIED ON HARDWARE HERE.
#pragma once

#include <cstdint>

#include "bsp/stm32h743/regs.hpp"

namespace piezoloop::bsp::stm32 {

inline bool dcache_enabled() { return (reg(core::kScbCcr) & core::kCcrDc) != 0u; }

// Invalidates every line (their content is undefined after reset), then
// enables the cache. Call once, before any data is kept in cacheable RAM.
inline void dcache_enable() {
    if (dcache_enabled()) return;
    reg(core::kScbCsselr) = 0;  // level 1, data
    asm volatile("dsb" ::: "memory");
    const uint32_t ccsidr = reg(core::kScbCcsidr);
    const uint32_t sets = ((ccsidr >> 13) & 0x7FFFu) + 1u;
    const uint32_t ways = ((ccsidr >> 3) & 0x3FFu) + 1u;
    const uint32_t line_shift = (ccsidr & 7u) + 4u;  // log2 of the line's bytes
    uint32_t way_shift = 32;                          // 32 - ceil(log2(ways))
    for (uint32_t w = ways - 1u; w != 0u; w >>= 1) --way_shift;
    for (uint32_t set = 0; set < sets; ++set)
        for (uint32_t way = 0; way < ways; ++way)
            reg(core::kScbDcisw) = (way_shift < 32 ? way << way_shift : 0u) | (set << line_shift);
    asm volatile("dsb" ::: "memory");
    reg(core::kScbCcr) = reg(core::kScbCcr) | core::kCcrDc;
    asm volatile("dsb\n\tisb" ::: "memory");
}

// Drops the cached copies of [address, address + bytes): the next read
// fetches memory. Harmless with the cache off.
inline void dcache_invalidate(uintptr_t address, uint32_t bytes) {
    constexpr uintptr_t kLine = 32;
    asm volatile("dsb" ::: "memory");
    for (uintptr_t a = address & ~(kLine - 1u); a < address + bytes; a += kLine) reg(core::kScbDcimvac) = a;
    asm volatile("dsb\n\tisb" ::: "memory");
}

}  // namespace piezoloop::bsp::stm32
