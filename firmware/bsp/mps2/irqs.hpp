// MPS2 AN385/AN500 interrupt lines used by the BSP (AN385 application note,
// interrupt map; QEMU hw/arm/mps2.c): 8 = CMSDK TIMER0, the control tick.
#pragma once

#include "bsp/cortex-m/irq_binding.hpp"

extern "C" void piezoloop_tick_timer_isr() noexcept;

namespace piezoloop::bsp {
inline constexpr IrqBinding kIrqBindings[] = {
    {8, piezoloop_tick_timer_isr},
};
}  // namespace piezoloop::bsp
