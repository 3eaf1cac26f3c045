// Nested vectored interrupt controller (ARMv7-M ARM B3.4): enable, disable,
// pending and priority of external interrupt n. Same on every Cortex-M3/M7.
#pragma once

#include <cstdint>

namespace piezoloop::bsp::nvic {

inline volatile uint32_t& word(uintptr_t address) { return *reinterpret_cast<volatile uint32_t*>(address); }

inline constexpr uintptr_t kIser = 0xE000E100;  // set-enable, one bit per interrupt
inline constexpr uintptr_t kIcer = 0xE000E180;  // clear-enable
inline constexpr uintptr_t kIcpr = 0xE000E280;  // clear-pending
inline constexpr uintptr_t kIpr = 0xE000E400;   // priority, one byte per interrupt

inline void enable(int irq) { word(kIser + 4u * (static_cast<uint32_t>(irq) >> 5)) = 1u << (irq & 31); }
inline void disable(int irq) {
    word(kIcer + 4u * (static_cast<uint32_t>(irq) >> 5)) = 1u << (irq & 31);
    asm volatile("dsb\n\tisb" ::: "memory");  // no further entry after this returns
}
inline void clear_pending(int irq) { word(kIcpr + 4u * (static_cast<uint32_t>(irq) >> 5)) = 1u << (irq & 31); }
// Priority 0 is the most urgent; only the implemented upper bits count
// (3 on MPS2 in QEMU, 4 on the STM32H7), so pass a value in the top bits.
inline void set_priority(int irq, uint8_t priority) {
    *reinterpret_cast<volatile uint8_t*>(kIpr + static_cast<uint32_t>(irq)) = priority;
}

}  // namespace piezoloop::bsp::nvic
