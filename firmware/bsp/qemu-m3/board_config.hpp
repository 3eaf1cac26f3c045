// Board constants of qemu-m3 (Cortex-M3, Q31 core). The rest is shared by both MPS2
// boards: bsp/mps2/board_config.hpp.
#pragma once

#include "bsp/mps2/board_config.hpp"

namespace piezoloop::bsp::config {

// Budget of the controller's tick (ADC read to DAC write, reference pipeline
// with all blocks), instructions under -icount shift=0.
inline constexpr uint32_t kTickBudget = 800;

// The multi-axis self-test case (app/selftest_axes_cases.hpp): two axes of
// that pipeline in Q31 at 50 kHz. The single-axis budget, 800 instructions
// ADC read to DAC write in a 100 kHz period of 10 000, is 8 % of the
// period; at 50 kHz (20 000) the same share is 1600 for the two axes' ADC
// reads to DAC writes, and twice that for the whole controller tick (the
// M7's ratio of its two budgets). The one-axis run is held to the same.
inline constexpr int kSelfTestAxes = 2;
inline constexpr uint32_t kAxesTickBudget = 1600;
inline constexpr uint32_t kAxesWholeTickBudget = 3200;

}  // namespace piezoloop::bsp::config
