// Board constants of qemu-m3 (Cortex-M3, Q31 core). The rest is shared by both MPS2
// boards: bsp/mps2/board_config.hpp.
#pragma once

#include "bsp/mps2/board_config.hpp"

namespace piezoloop::bsp::config {

// Budget of the controller's tick (ADC read to DAC write, reference pipeline
// with all blocks), instructions under -icount shift=0.
inline constexpr uint32_t kTickBudget = 800;

}  // namespace piezoloop::bsp::config
