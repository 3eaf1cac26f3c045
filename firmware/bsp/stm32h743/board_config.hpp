// Board constants of the NUCLEO-H743ZI2 (STM32H743ZI, Cortex-M7 at 480 MHz
// once the clock tree is up; see board.cpp).
#pragma once

#include <cstdint>

#include "piezoloop/limits.hpp"

namespace piezoloop::bsp::config {

inline constexpr uint32_t kCpuClock_Hz = 64'000'000;        // HSI, reset clock tree (for now)
inline constexpr uint32_t kTickTimerClock_Hz = 64'000'000;  // TIM6 on APB1 x1
inline constexpr int kTickIrq = 54;                         // TIM6_DAC
inline constexpr uint32_t kTimestamp_Hz = kCpuClock_Hz;     // DWT CYCCNT
inline constexpr uint32_t kTimestampMask = 0xFFFFFFFFu;
inline constexpr const char* kWorkUnit = "cycles";
inline constexpr uint32_t kStopwatchResolution = 1;
inline constexpr uint32_t kTickBudget = 300;

// Analog front end (docs/boards.md): ±50 µm sensor on a 16-bit ADC, a
// ±12 V-referred DAC output, amplifier and piezo rated ±10 V.
inline constexpr float kPositionFullScale_um = 50.0f;
inline constexpr float kVoltageFullScale_V = 12.0f;
inline constexpr HardLimits kHardLimits{-10.0f, 10.0f, 2.0e5f};
inline constexpr bool kHasConverters = true;
inline constexpr uint32_t kOverrunTestRate_Hz = 4'000'000;  // 16 cycles per period

}  // namespace piezoloop::bsp::config
