// ARM CMSDK APB timer (Cortex-M System Design Kit TRM, ARM DDI 0479C, 4.4):
// a 32-bit down counter on PCLK. MPS2 AN385/AN500 have TIMER0 at 0x40000000
// (IRQ 8) and TIMER1 at 0x40001000 (IRQ 9), PCLK 25 MHz.
// Registers (offsets from the base):
//   0x000 CTRL       bit 0 enable, bit 3 interrupt enable (bits 1, 2: EXTIN)
//   0x004 VALUE      current count
//   0x008 RELOAD     reload value; writing it also loads VALUE
//   0x00C INTSTATUS  bit 0 interrupt pending / INTCLEAR: write 1 to clear
// The counter counts RELOAD, ..., 1, 0 and reloads: one period is
// RELOAD + 1 clocks, the interrupt is raised on the 1 -> 0 transition and
// stays asserted (level) until cleared (QEMU hw/timer/cmsdk-apb-timer.c
// models it so).
#pragma once

#include <cstdint>

namespace piezoloop::bsp::mps2 {

class CmsdkTimer {
public:
    explicit constexpr CmsdkTimer(uintptr_t base) : base_(base) {}

    // Periodic interrupt every `period_clocks` PCLK cycles (>= 2).
    void start_periodic(uint32_t period_clocks) const {
        reg(kCtrl) = 0;
        reg(kIntClear) = kIntPending;
        reg(kReload) = period_clocks - 1u;
        reg(kCtrl) = kCtrlEnable | kCtrlIrqEnable;
    }
    void stop() const {
        reg(kCtrl) = 0;
        reg(kIntClear) = kIntPending;
    }
    bool running() const { return (reg(kCtrl) & kCtrlEnable) != 0u; }
    void clear_interrupt() const { reg(kIntClear) = kIntPending; }
    bool interrupt_pending() const { return (reg(kIntStatus) & kIntPending) != 0u; }
    uint32_t value() const { return reg(kValue); }

private:
    static constexpr uintptr_t kCtrl = 0x000;
    static constexpr uintptr_t kValue = 0x004;
    static constexpr uintptr_t kReload = 0x008;
    static constexpr uintptr_t kIntStatus = 0x00C;
    static constexpr uintptr_t kIntClear = 0x00C;
    static constexpr uint32_t kCtrlEnable = 1u << 0;
    static constexpr uint32_t kCtrlIrqEnable = 1u << 3;
    static constexpr uint32_t kIntPending = 1u << 0;

    volatile uint32_t& reg(uintptr_t offset) const {
        return *reinterpret_cast<volatile uint32_t*>(base_ + offset);
    }

    uintptr_t base_;
};

}  // namespace piezoloop::bsp::mps2
