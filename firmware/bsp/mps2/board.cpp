// Board support shared by the two QEMU MPS2 boards (mps2-an385 Cortex-M3,
// mps2-an500 Cortex-M7): console on CMSDK UART0, exit through semihosting.
// Both FPGA images put UART0 at 0x40004000 and clock the APB at 25 MHz
// (AN385/AN500; QEMU hw/arm/mps2.c SYSCLK_FRQ).
#include "bsp/bsp.hpp"
#include "bsp/cortex-m/semihosting.hpp"
#include "bsp/mps2/cmsdk_uart.hpp"

namespace piezoloop::bsp {

namespace {
constexpr mps2::CmsdkUart kUart0{0x40004000};
constexpr uint32_t kSysClk_Hz = 25'000'000;
constexpr uint32_t kConsoleBaud = 115'200;
}  // namespace

void init() { kUart0.enable_tx(kSysClk_Hz, kConsoleBaud); }

void console_write(const char* text, std::size_t length) {
    for (std::size_t i = 0; i < length; ++i) kUart0.put(text[i]);
}

void exit(int status) {
    // QEMU is always run with -semihosting for these boards.
    semihosting::exit(status);
    for (;;) asm volatile("wfi");
}

}  // namespace piezoloop::bsp
