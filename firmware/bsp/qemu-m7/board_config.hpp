// Board constants of qemu-m7 (Cortex-M7, float core). The rest is shared by both MPS2
// boards: bsp/mps2/board_config.hpp.
#pragma once

#include "bsp/mps2/board_config.hpp"

namespace piezoloop::bsp::config {

// Budget of the controller's tick (ADC read to DAC write, reference pipeline
// with all blocks), instructions under -icount shift=0.
inline constexpr uint32_t kTickBudget = 300;

// The multi-axis self-test case (app/selftest_axes_cases.hpp): up to three
// axes of that pipeline at 100 kHz. Budgets of the three-axis tick: ADC
// reads to DAC writes, and the whole controller tick -- 1200 instructions
// at CPI 1 are 25 % of a 100 kHz period on a 480 MHz Cortex-M7 (STM32H743).
// The runs with fewer axes are held to the same figures.
inline constexpr int kSelfTestAxes = 3;
inline constexpr uint32_t kAxesTickBudget = 600;
inline constexpr uint32_t kAxesWholeTickBudget = 1200;

}  // namespace piezoloop::bsp::config
