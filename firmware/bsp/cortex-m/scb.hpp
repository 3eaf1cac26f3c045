// Cortex-M system control registers used by the startup and fault code
// (ARMv7-M Architecture Reference Manual, B3.2: System Control Space).
// Same addresses on every Cortex-M3/M4/M7.
#pragma once

#include <cstdint>

namespace piezoloop::bsp::scb {

inline volatile uint32_t& reg(uintptr_t address) {
    return *reinterpret_cast<volatile uint32_t*>(address);
}

inline constexpr uintptr_t kVtor = 0xE000ED08;   // vector table offset
inline constexpr uintptr_t kCfsr = 0xE000ED28;   // configurable fault status (MMFSR|BFSR|UFSR)
inline constexpr uintptr_t kHfsr = 0xE000ED2C;   // hard fault status
inline constexpr uintptr_t kMmfar = 0xE000ED34;  // memory-manage fault address
inline constexpr uintptr_t kBfar = 0xE000ED38;   // bus fault address
inline constexpr uintptr_t kCpacr = 0xE000ED88;  // coprocessor access control (CP10/CP11 = FPU)
inline constexpr uintptr_t kDhcsr = 0xE000EDF0;  // debug halting control/status
inline constexpr uintptr_t kMvfr0 = 0xE000EF40;  // media and VFP feature register 0 (FPU boards)

inline constexpr uint32_t kDhcsrDebugEnabled = 1u << 0;  // C_DEBUGEN: a debugger is attached

}  // namespace piezoloop::bsp::scb
