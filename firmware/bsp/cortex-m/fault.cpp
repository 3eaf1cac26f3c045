// Fault and unexpected-exception handlers: print what happened on the
// console (one line starting with "fault"), then bsp::exit() with a status
// the QEMU test sees as a failure. On hardware the line is the post-mortem.
#include <cstdint>

#include "bsp/bsp.hpp"
#include "bsp/cortex-m/scb.hpp"
#include "bsp/text.hpp"

namespace {

uint32_t ipsr() {
    uint32_t value;
    asm volatile("mrs %0, ipsr" : "=r"(value));
    return value & 0x1FFu;  // active exception number
}

}  // namespace

extern "C" {

// frame: the registers the core stacked on exception entry
// (r0, r1, r2, r3, r12, lr, pc, xpsr).
[[noreturn]] __attribute__((used)) void piezoloop_fault_report(const uint32_t* frame) {
    using namespace piezoloop::bsp;
    TextLine line;
    line.str("fault");
    line.key("exception").udec(ipsr());
    line.key("pc").hex(frame[6]);
    line.key("lr").hex(frame[5]);
    line.key("cfsr").hex(scb::reg(scb::kCfsr));
    line.key("hfsr").hex(scb::reg(scb::kHfsr));
    line.key("mmfar").hex(scb::reg(scb::kMmfar));
    line.key("bfar").hex(scb::reg(scb::kBfar));
    line.key("board").str(kBoardName);
    line.flush();
    exit(kExitFault);
}

// Naked: find the stacked frame before the compiler touches the stack.
// EXC_RETURN bit 2 in lr tells whether the interrupted code used PSP or MSP.
__attribute__((naked)) void piezoloop_fault_entry() noexcept {
    asm volatile(
        "tst   lr, #4\n\t"
        "ite   eq\n\t"
        "mrseq r0, msp\n\t"
        "mrsne r0, psp\n\t"
        "b     piezoloop_fault_report\n\t");
}

void NMI_Handler() noexcept __attribute__((alias("piezoloop_fault_entry")));
void HardFault_Handler() noexcept __attribute__((alias("piezoloop_fault_entry")));
void MemManage_Handler() noexcept __attribute__((alias("piezoloop_fault_entry")));
void BusFault_Handler() noexcept __attribute__((alias("piezoloop_fault_entry")));
void UsageFault_Handler() noexcept __attribute__((alias("piezoloop_fault_entry")));

// Every exception or interrupt without its own handler.
void piezoloop_default_handler() noexcept {
    using namespace piezoloop::bsp;
    TextLine line;
    line.str("fault unexpected");
    line.key("exception").udec(ipsr());
    line.key("board").str(kBoardName);
    line.flush();
    exit(kExitUnexpectedIrq);
}

// Weak: the application defines the real ones when it uses them.
void SVC_Handler() noexcept __attribute__((weak, alias("piezoloop_default_handler")));
void DebugMon_Handler() noexcept __attribute__((weak, alias("piezoloop_default_handler")));
void PendSV_Handler() noexcept __attribute__((weak, alias("piezoloop_default_handler")));
void SysTick_Handler() noexcept __attribute__((weak, alias("piezoloop_default_handler")));

}  // extern "C"
