// NUCLEO-H743ZI2 board support, minimal: console on USART3 (PD8 TX, PD9 RX,
// AF7), which the board routes to the ST-LINK virtual COM port; clocks left
// at their reset state. Full clock tree (PLL, 480 MHz), caches, ADC/DAC and
// the tick timer come with the full firmware.
//
// NOT RUN HERE (no hardware, no QEMU model): addresses are from RM0433 and
// the STM32H743 device header, checked by review only.
//
// Reset clocks (RM0433, RCC): sys_ck = HSI = 64 MHz, all bus prescalers 1,
// USART2/3/4/5/7/8 kernel clock = rcc_pclk1 = 64 MHz.
#include <cstdint>

#include "bsp/bsp.hpp"
#include "bsp/cortex-m/scb.hpp"
#include "bsp/cortex-m/semihosting.hpp"

namespace piezoloop::bsp {

namespace {

volatile uint32_t& reg(uintptr_t address) { return *reinterpret_cast<volatile uint32_t*>(address); }

// RCC (D3 AHB4, 0x58024400)
constexpr uintptr_t kRccAhb4Enr = 0x58024400 + 0x0E0;
constexpr uintptr_t kRccApb1lEnr = 0x58024400 + 0x0E8;
constexpr uint32_t kRccAhb4EnrGpioD = 1u << 3;
constexpr uint32_t kRccApb1lEnrUsart3 = 1u << 18;

// GPIOD (D3 AHB4, 0x58020C00)
constexpr uintptr_t kGpioDModer = 0x58020C00 + 0x00;
constexpr uintptr_t kGpioDAfrh = 0x58020C00 + 0x24;  // alternate function, pins 8..15

// USART3 (D2 APB1, 0x40004800)
constexpr uintptr_t kUsart3Cr1 = 0x40004800 + 0x00;
constexpr uintptr_t kUsart3Brr = 0x40004800 + 0x0C;
constexpr uintptr_t kUsart3Isr = 0x40004800 + 0x1C;
constexpr uintptr_t kUsart3Tdr = 0x40004800 + 0x28;
constexpr uint32_t kCr1Ue = 1u << 0;   // USART enable
constexpr uint32_t kCr1Te = 1u << 3;   // transmitter enable
constexpr uint32_t kIsrTc = 1u << 6;   // transmission complete
constexpr uint32_t kIsrTxe = 1u << 7;  // TX data register empty (TXFNF with FIFO)

constexpr uint32_t kPclk1_Hz = 64'000'000;
constexpr uint32_t kConsoleBaud = 115'200;

// A fault before init() must not poll an unclocked USART forever.
bool g_console_ready = false;

}  // namespace

void init() {
    reg(kRccAhb4Enr) = reg(kRccAhb4Enr) | kRccAhb4EnrGpioD;
    reg(kRccApb1lEnr) = reg(kRccApb1lEnr) | kRccApb1lEnrUsart3;
    // Read back: the enable crosses a bus bridge and must land before the
    // peripheral is accessed (RM0433, RCC peripheral clock enable).
    const uint32_t readback = reg(kRccAhb4Enr) | reg(kRccApb1lEnr);
    (void)readback;

    // PD8, PD9: alternate function mode (0b10), AF7 = USART3.
    reg(kGpioDModer) = (reg(kGpioDModer) & ~(0xFu << 16)) | (0xAu << 16);
    reg(kGpioDAfrh) = (reg(kGpioDAfrh) & ~0xFFu) | 0x77u;

    // 115200 8N1, oversampling by 16: BRR = f_ck / baud, rounded.
    reg(kUsart3Cr1) = 0;
    reg(kUsart3Brr) = (kPclk1_Hz + kConsoleBaud / 2) / kConsoleBaud;
    reg(kUsart3Cr1) = kCr1Ue | kCr1Te;
    g_console_ready = true;
}

void console_write(const char* text, std::size_t length) {
    if (!g_console_ready) return;
    for (std::size_t i = 0; i < length; ++i) {
        while ((reg(kUsart3Isr) & kIsrTxe) == 0u) {
        }
        reg(kUsart3Tdr) = static_cast<uint8_t>(text[i]);
    }
}

void exit(int status) {
    if (g_console_ready) {
        while ((reg(kUsart3Isr) & kIsrTc) == 0u) {
        }
    }
    // Semihosting only with a debugger attached: without one, BKPT would
    // escalate to a HardFault.
    if ((scb::reg(scb::kDhcsr) & scb::kDhcsrDebugEnabled) != 0u) semihosting::exit(status);
    for (;;) asm volatile("wfi");
}

}  // namespace piezoloop::bsp
