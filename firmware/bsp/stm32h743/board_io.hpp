// The tick's converters on the NUCLEO-H743ZI2. Inline: they are part of the
// measured tick. Until the analog front end is wired (board.cpp) they go to
// the emulated stage; in loopback (self-test without a stage) always.
#pragma once

#include <cstdint>

#include "bsp/emulated_stage.hpp"

namespace piezoloop::bsp {

namespace stm32 {
extern fw::EmulatedStage g_emulated_stage;  // board.cpp
extern bool g_loopback;
}  // namespace stm32

inline int32_t adc_read() { return stm32::g_emulated_stage.adc_code(); }
inline void dac_write(int32_t code) { stm32::g_emulated_stage.dac_write(code); }

}  // namespace piezoloop::bsp
