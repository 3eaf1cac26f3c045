// An external interrupt line and its handler, for the vector table that
// startup.cpp builds at compile time from a board's kIrqBindings.
#pragma once

namespace piezoloop::bsp {

struct IrqBinding {
    int irq;                  // external interrupt number (vector 16 + irq)
    void (*handler)() noexcept;
};

}  // namespace piezoloop::bsp
