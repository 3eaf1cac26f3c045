// STM32H743 interrupt lines the BSP handles (RM0433, NVIC vector table):
//   54  TIM6_DAC TIM6 update: the control tick (its TRGO starts the ADC)
//  101  OTG_FS   USB device (OTG2, full speed)
// Included by startup.cpp.
#pragma once

#include "bsp/cortex-m/irq_binding.hpp"

extern "C" void piezoloop_tick_timer_isr() noexcept;
extern "C" void piezoloop_usb_otg_fs_isr() noexcept;

namespace piezoloop::bsp {
inline constexpr IrqBinding kIrqBindings[] = {
    {54, piezoloop_tick_timer_isr},
    {101, piezoloop_usb_otg_fs_isr},
};
}  // namespace piezoloop::bsp
