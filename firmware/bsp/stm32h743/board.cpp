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

#include "board_config.hpp"
#include "board_io.hpp"
#include "bsp/bsp.hpp"
#include "bsp/cortex-m/nvic.hpp"
#include "bsp/cortex-m/scb.hpp"
#include "bsp/cortex-m/semihosting.hpp"
#include "bsp/emulated_stage.hpp"

namespace piezoloop::bsp {

namespace stm32 {
fw::EmulatedStage g_emulated_stage{config::kPositionFullScale_um, config::kVoltageFullScale_V};
bool g_loopback = false;
}  // namespace stm32

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
constexpr uint32_t kCr1Re = 1u << 2;   // receiver enable
constexpr uintptr_t kUsart3Rdr = 0x40004800 + 0x24;
constexpr uint32_t kIsrRxne = 1u << 5;  // RX data register not empty
constexpr uint32_t kIsrTc = 1u << 6;   // transmission complete
constexpr uint32_t kIsrTxe = 1u << 7;  // TX data register empty (TXFNF with FIFO)

constexpr uint32_t kPclk1_Hz = 64'000'000;
constexpr uint32_t kConsoleBaud = 115'200;

// A fault before init() must not poll an unclocked USART forever.
bool g_console_ready = false;

// TIM6 (APB1L, 0x40001000): the control tick.
constexpr uintptr_t kRccApb1lEnrTim6 = 1u << 4;
constexpr uintptr_t kTim6 = 0x40001000;
constexpr uintptr_t kTimCr1 = 0x00, kTimDier = 0x0C, kTimSr = 0x10, kTimEgr = 0x14, kTimPsc = 0x28,
                    kTimArr = 0x2C;
constexpr uint32_t kCr1Cen = 1u << 0, kCr1Urs = 1u << 2, kDierUie = 1u << 0, kSrUif = 1u << 0, kEgrUg = 1u << 0;

// DWT cycle counter (ARMv7-M ARM C1.8): DEMCR.TRCENA, DWT_CTRL.CYCCNTENA;
// the Cortex-M7 DWT is locked until the CoreSight key is written to LAR.
constexpr uintptr_t kDemcr = 0xE000EDFC;
constexpr uintptr_t kDwtCtrl = 0xE0001000, kDwtCyccnt = 0xE0001004, kDwtLar = 0xE0001FB0;

TickHandler g_tick_handler = nullptr;
uint32_t g_stopwatch_offset = 0;

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
    reg(kUsart3Cr1) = kCr1Ue | kCr1Te | kCr1Re;
    g_console_ready = true;

    reg(kDemcr) = reg(kDemcr) | (1u << 24);
    reg(kDwtLar) = 0xC5ACCE55u;
    reg(kDwtCyccnt) = 0;
    reg(kDwtCtrl) = reg(kDwtCtrl) | 1u;
    // The stopwatch's own cost: two reads of CYCCNT around nothing.
    const uint32_t s = stopwatch_start();
    g_stopwatch_offset = stopwatch_elapsed(s);

    reg(kRccApb1lEnr) = reg(kRccApb1lEnr) | kRccApb1lEnrTim6;
    const uint32_t readback2 = reg(kRccApb1lEnr);  // the enable must land first
    (void)readback2;
}

void console_write(const char* text, std::size_t length) {
    if (!g_console_ready) return;
    for (std::size_t i = 0; i < length; ++i) {
        while ((reg(kUsart3Isr) & kIsrTxe) == 0u) {
        }
        reg(kUsart3Tdr) = static_cast<uint8_t>(text[i]);
    }
}

bool console_read(char& c) {
    if (!g_console_ready || (reg(kUsart3Isr) & kIsrRxne) == 0u) return false;
    c = static_cast<char>(reg(kUsart3Rdr) & 0xFFu);
    return true;
}

bool tick_timer_start(uint32_t rate_Hz, TickHandler handler) {
    if (rate_Hz == 0 || handler == nullptr || config::kTickTimerClock_Hz % rate_Hz != 0u) return false;
    const uint32_t period = config::kTickTimerClock_Hz / rate_Hz;
    if (period < 2u || period > 65536u) return false;
    tick_timer_stop();
    g_tick_handler = handler;
    reg(kTim6 + kTimPsc) = 0;
    reg(kTim6 + kTimArr) = period - 1u;
    reg(kTim6 + kTimCr1) = kCr1Urs;      // only overflow sets UIF, not the UG below
    reg(kTim6 + kTimEgr) = kEgrUg;       // load PSC/ARR now
    reg(kTim6 + kTimSr) = 0;
    reg(kTim6 + kTimDier) = kDierUie;
    nvic::set_priority(config::kTickIrq, 0x00);
    nvic::clear_pending(config::kTickIrq);
    nvic::enable(config::kTickIrq);
    reg(kTim6 + kTimCr1) = kCr1Urs | kCr1Cen;
    return true;
}

void tick_timer_stop() {
    reg(kTim6 + kTimCr1) = 0;
    reg(kTim6 + kTimDier) = 0;
    reg(kTim6 + kTimSr) = 0;
    nvic::disable(config::kTickIrq);
    nvic::clear_pending(config::kTickIrq);
}

bool tick_timer_running() { return (reg(kTim6 + kTimCr1) & kCr1Cen) != 0u; }

void wait_for_interrupt() { asm volatile("dsb\n\twfi" ::: "memory"); }

uint32_t timestamp() { return reg(kDwtCyccnt); }
uint32_t stopwatch_start() { return reg(kDwtCyccnt); }
uint32_t stopwatch_elapsed(uint32_t start) { return reg(kDwtCyccnt) - start - g_stopwatch_offset; }

fw::EmulatedStage& emulated_stage() { return stm32::g_emulated_stage; }
void emulated_stage_step() {
    if (stm32::g_loopback) stm32::g_emulated_stage.step();
}
bool set_loopback(bool on) {
    stm32::g_loopback = on;
    return true;
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

extern "C" void piezoloop_tick_timer_isr() noexcept {
    using namespace piezoloop::bsp;
    reg(kTim6 + kTimSr) = 0;  // clear UIF first: an overrun re-pends the interrupt
    g_tick_handler();
}
