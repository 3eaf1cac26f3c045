// Constants of the two QEMU MPS2 boards (AN385 Cortex-M3, AN500 Cortex-M7)
// as the firmware sees them. Included through bsp/qemu-m*/board_config.hpp.
#pragma once

#include <cstdint>

#include "piezoloop/limits.hpp"

namespace piezoloop::bsp::config {

// Nominal FPGA clock of the MPS2 images: CPU, APB timers, UART and SysTick
// all run on it (QEMU hw/arm/mps2.c SYSCLK_FRQ). Under -icount shift=0 QEMU
// instead executes one instruction per virtual nanosecond, i.e. the CPU
// behaves as a 1 GHz, one-instruction-per-cycle core while the timers keep
// their 25 MHz: one 100 kHz period is 10 000 instructions.
inline constexpr uint32_t kCpuClock_Hz = 25'000'000;
inline constexpr uint32_t kTickTimerClock_Hz = 25'000'000;  // CMSDK TIMER0 on PCLK
inline constexpr int kTickIrq = 8;                          // TIMER0
inline constexpr uint32_t kTimestamp_Hz = 25'000'000;      // SysTick on the CPU clock
inline constexpr uint32_t kTimestampMask = 0x00FFFFFFu;     // 24-bit
// QEMU's virtual nanoseconds per instruction under -icount shift=0.
inline constexpr uint32_t kEmulatedNsPerInsn = 1;
inline constexpr const char* kWorkUnit = "insn";
inline constexpr uint32_t kStopwatchResolution = 3;  // max error, instructions: bsp/cortex-m/systick.hpp

// The emulated stage is the reference stage (common/piezoloop/
// reference_stage.hpp): a ±10 V bender read by a 50 µm sensor. Converters:
// 16-bit ADC over ±50 µm, 16-bit DAC over ±12 V (the amplifier's swing
// referred to the piezo), the same full scales as reference::setup().
inline constexpr float kPositionFullScale_um = 50.0f;
inline constexpr float kVoltageFullScale_V = 12.0f;
// Hard output limits of this board's amplifier and piezo, compiled in: the
// pipeline is constructed with them and no parameter set can widen them.
inline constexpr HardLimits kHardLimits{-10.0f, 10.0f, 2.0e5f};
inline constexpr bool kHasConverters = false;  // ADC/DAC are the emulated stage
// A tick rate the board cannot sustain (5 MHz = 200 instructions per period
// under -icount shift=0, less than the tick alone): the self-test runs the
// loop there briefly to prove that overruns are counted.
inline constexpr uint32_t kOverrunTestRate_Hz = 5'000'000;

}  // namespace piezoloop::bsp::config
