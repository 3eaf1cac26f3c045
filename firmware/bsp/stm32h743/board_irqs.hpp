// STM32H743 interrupt lines the BSP handles (RM0433, table "NVIC"):
// 54 = TIM6_DAC (TIM6 update: the control tick). Included by startup.cpp.
#pragma once

#include "bsp/cortex-m/irq_binding.hpp"

extern "C" void piezoloop_tick_timer_isr() noexcept;

namespace piezoloop::bsp {
inline constexpr IrqBinding kIrqBindings[] = {
    {54, piezoloop_tick_timer_isr},
};
}  // namespace piezoloop::bsp
