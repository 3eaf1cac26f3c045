// The tick's converters on the QEMU MPS2 boards: the emulated stage
// (bsp/emulated_stage.hpp) stands behind both. Inline: they are part of the
// measured tick. Included through bsp/qemu-m*/board_io.hpp.
#pragma once

#include <cstdint>

#include "bsp/emulated_stage.hpp"

namespace piezoloop::bsp {

namespace mps2 {
extern fw::EmulatedStage g_emulated_stage;  // board.cpp
}  // namespace mps2

inline int32_t adc_read() { return mps2::g_emulated_stage.adc_code(); }
inline void dac_write(int32_t code) { mps2::g_emulated_stage.dac_write(code); }

}  // namespace piezoloop::bsp
