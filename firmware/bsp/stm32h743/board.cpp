// NUCLEO-H743ZI2 board support (STM32H743ZI, rev V): written from RM0433 and
// UM2407; no vendor headers. NOT RUN HERE: there is no hardware and no QEMU
// model of this part; it builds, links and fits, and the register values
// are checked by review only. docs/boards.md says how to flash and wire it.
//
//   clocks    clock.cpp: HSE 8 MHz bypass (ST-LINK MCO) -> PLL1 480 MHz, VOS0
//   caches    I-cache on (code runs from flash); D-cache off: data, bss and
//             the stack are in DTCM, which is never cached
//   console   USART3 on PD8/PD9 (AF7) -> ST-LINK virtual COM port, 115200 8N1
//   tick      TIM6 at 100 kHz: the update starts an ADC1 conversion (TRGO)
//             and runs the tick in its interrupt: the pipeline's
//             reading-independent half while the ADC converts, then wait
//             for end of conversion, sample, compute, DAC. In loopback
//             (self-test, no stage) against the emulated stage instead.
//   ADC       ADC1, 16 bit, channel INP15 on PA3 (Zio A0), 8.5-cycle
//             sampling, offset binary: code = raw - 32768
//   DAC       DAC1 channel 1 on PA4, 12 bit, buffered: dac = (code + 32768) >> 4,
//             written immediately (no trigger): the output changes one APB
//             cycle after the tick writes it
//   axes      the three-axis image (servo_xyz.elf) adds ADC2 and ADC3 on the
//             same trigger, DAC1 channel 2 and an external DAC on SPI3
//             (board_io.hpp), with its axes in AXI SRAM and the data cache on
//   timing    DWT CYCCNT (480 MHz) for timestamps and the stopwatch
//   LEDs      LD1 green PB0: heartbeat; LD3 red PB14: fault / trip
//   USB       usb_otg_fs.cpp: vendor device on CN13, bulk EP1 OUT/IN; the
//             console is mirrored to EP1 IN and input is also read from
//             EP1 OUT, so servo.elf's link frames travel over USB as well
//             (use one of the two at a time: both feed one frame decoder)
//   serial    the 96-bit unique device ID as 24 hex digits: the USB serial
//             number string and the link's HelloReply serial
#include <cstdint>

#include "board_config.hpp"
#include "board_io.hpp"
#include "bsp/bsp.hpp"
#include "bsp/cortex-m/nvic.hpp"
#include "bsp/cortex-m/scb.hpp"
#include "bsp/cortex-m/semihosting.hpp"
#include "bsp/stm32h743/dcache.hpp"
#include "bsp/stm32h743/regs.hpp"
#include "bsp/stm32h743/usb_otg_fs.hpp"
#include "piezoloop/emulated_stage.hpp"
#include "piezoloop/usb/serial_number.hpp"

namespace piezoloop::bsp {

namespace stm32 {
EmulatedStage<fw::CoreSample> g_emulated_stage;
bool g_loopback = false;
bool clock_init();  // clock.cpp
}  // namespace stm32

namespace {

using namespace stm32;

constexpr uint32_t kConsoleBaud = 115'200;
constexpr uint8_t kTickPriority = 0x00;

TickHandler g_tick_handler = nullptr;
uint32_t g_stopwatch_offset = 0;
bool g_console_ready = false;
bool g_usb_ready = false;
bool g_timer_running = false;
int g_converter_axes = 1;  // axes whose converters run: 1, or 2 and 3 in the three-axis image
usb::UniqueIdSerial g_serial{};  // filled on first use (before USB connects)

void enable_clocks() {
    using namespace rcc;
    reg(kAhb4enr) = reg(kAhb4enr) | kAhb4GpioAEn | kAhb4GpioBEn | kAhb4GpioDEn | kAhb4GpioEEn;
    reg(kAhb1enr) = reg(kAhb1enr) | kAhb1Adc12En;
    reg(kApb1lenr) = reg(kApb1lenr) | kApb1lTim6En | kApb1lUsart3En | kApb1lDac12En;
    // Read back: the enables cross bus bridges and must land before the
    // peripherals are touched (RM0433, RCC: "peripheral clock enable").
    const uint32_t readback = reg(kAhb4enr) | reg(kAhb1enr) | reg(kApb1lenr);
    (void)readback;
}

void console_init(uint32_t pclk1_Hz) {
    gpio::alternate(gpio::kPortD, 8, 7);  // USART3_TX
    gpio::alternate(gpio::kPortD, 9, 7);  // USART3_RX
    reg(usart3::kCr1) = 0;
    reg(usart3::kBrr) = (pclk1_Hz + kConsoleBaud / 2) / kConsoleBaud;
    reg(usart3::kCr1) = usart3::kCr1Ue | usart3::kCr1Te | usart3::kCr1Re;
    g_console_ready = true;
}

void icache_enable() {
    asm volatile("dsb\n\tisb" ::: "memory");
    reg(core::kScbIciallu) = 0;
    asm volatile("dsb\n\tisb" ::: "memory");
    reg(core::kScbCcr) = reg(core::kScbCcr) | (1u << 17);
    asm volatile("dsb\n\tisb" ::: "memory");
}

void dwt_init() {
    reg(core::kDemcr) = reg(core::kDemcr) | (1u << 24);  // TRCENA
    reg(core::kDwtLar) = 0xC5ACCE55u;                     // CoreSight unlock (Cortex-M7)
    reg(core::kDwtCyccnt) = 0;
    reg(core::kDwtCtrl) = reg(core::kDwtCtrl) | 1u;       // CYCCNTENA
}

void leds_init() {
    gpio::mode(gpio::kPortB, 0, gpio::kModeOutput);   // LD1 green
    gpio::mode(gpio::kPortB, 14, gpio::kModeOutput);  // LD3 red
    gpio::set(gpio::kPortB, 0, false);
    gpio::set(gpio::kPortB, 14, false);
}

// Busy wait on CYCCNT (start-up only).
void delay_us(uint32_t us) {
    const uint32_t start = reg(core::kDwtCyccnt);
    const uint32_t cycles = us * (config::kCpuClock_Hz / 1'000'000u);
    while (reg(core::kDwtCyccnt) - start < cycles) {
    }
}

// One axis's ADC: its input pin and channel, and whether its init sets the
// common prescaler (ADC1 and ADC2 share one, set by ADC1's while both are
// disabled).
struct AdcInput {
    uintptr_t adc;
    uintptr_t common;
    bool sets_prescaler;
    uintptr_t port;
    int pin;
    uint32_t channel;
};
constexpr AdcInput kAdcX{adc::kAdc1, adc::kCommon12, true, gpio::kPortA, 3, 15};
constexpr AdcInput kAdcY{adc::kAdc2, adc::kCommon12, false, gpio::kPortC, 0, 10};
constexpr AdcInput kAdcZ{adc::kAdc3, adc::kCommon3, true, gpio::kPortF, 10, 6};
constexpr uintptr_t kAdcs[] = {kAdcX.adc, kAdcY.adc, kAdcZ.adc};

// An ADC triggered by TIM6 TRGO (ADC1: PA3, INP15); the tick polls end of
// conversion (board_io.hpp adc_read), no ADC interrupt.
bool adc_init(const AdcInput& in) {
    using namespace adc;
    const uintptr_t a = in.adc;
    gpio::mode(in.port, in.pin, gpio::kModeAnalog);
    // per_ck (HSI 64 MHz) / 2 = 32 MHz: within the 16-bit limit of rev V.
    if (in.sets_prescaler) reg(in.common + kCcr) = kCcrPrescDiv2;
    reg(a + kCr) = 0;                        // leave deep power-down
    reg(a + kCr) = kCrAdvregen;              // regulator on
    delay_us(20);                            // TADCVREG_STUP is 10 µs
    reg(a + kCr) = kCrAdvregen | kCrBoost25To50MHz;
    reg(a + kCr) = kCrAdvregen | kCrBoost25To50MHz | kCrAdcallin | kCrAdcal;  // single-ended + linearity
    for (uint32_t i = 0; (reg(a + kCr) & kCrAdcal) != 0u; ++i)
        if (i > 10'000'000) return false;
    reg(a + kIsr) = kIsrAdrdy;
    reg(a + kCr) = reg(a + kCr) | kCrAden;
    for (uint32_t i = 0; (reg(a + kIsr) & kIsrAdrdy) == 0u; ++i)
        if (i > 10'000'000) return false;
    reg(a + kCfgr) = (kExtselTim6Trgo << kCfgrExtselShift) | kCfgrExtenRising | kCfgrOvrmod;  // 16 bit
    reg(a + kPcsel) = 1u << in.channel;
    // SMPn = 8.5 cycles: channels 0..9 in SMPR1, 10..19 in SMPR2, 3 bits each.
    if (in.channel < 10)
        reg(a + kSmpr1) = 2u << (3 * in.channel);
    else
        reg(a + kSmpr2) = 2u << (3 * (in.channel - 10));
    reg(a + kSqr1) = in.channel << 6;  // one conversion: that channel
    reg(a + kIsr) = kIsrEoc | kIsrOvr;
    reg(a + kIer) = 0;
    reg(a + kCr) = reg(a + kCr) | kCrAdstart;  // waits for triggers
    return true;
}

// DAC1 channel 1 on PA4, buffered output, mid-scale (0 V command) at start.
void dac_init() {
    gpio::mode(gpio::kPortA, 4, gpio::kModeAnalog);
    reg(dac::kMcr) = 0;  // channels 1 and 2: normal mode, buffer on, to the pin
    reg(dac::kDhr12r1) = 2048;
    reg(dac::kCr) = dac::kCrEn1;
}

// SPI3 as the master of z's external DAC (board_io.hpp): 16-bit frames,
// transmit only, mode 0, the kernel clock pll1_q_ck (48 MHz, the reset
// choice of SPI123SEL) / 2 = 24 MHz; slave select managed in software, the
// chip select a GPIO. Left running (CSTART): each frame written to TXDR
// goes out at once.
void spi_dac_init() {
    using namespace spi3;
    gpio::alternate(gpio::kPortC, 10, 6);  // SPI3_SCK
    gpio::alternate(gpio::kPortC, 12, 6);  // SPI3_MOSI
    gpio::speed_very_high(gpio::kPortC, 10);
    gpio::speed_very_high(gpio::kPortC, 12);
    gpio::set(gpio::kPortA, 15, true);  // chip select idle high
    gpio::mode(gpio::kPortA, 15, gpio::kModeOutput);
    reg(kCr1) = 0;                                      // configured while SPE is 0
    reg(kCfg1) = kCfg1Dsize16 | (kCfg1Dsize16 << 16);  // 16-bit frames (CRCSIZE alike; CRC off), MBR /2
    reg(kCfg2) = kCfg2Afcntr | kCfg2Ssm | kCfg2Master | kCfg2CommTx;
    reg(kCr2) = 0;  // TSIZE 0: frames as they come
    reg(kCr1) = kCr1Ssi;
    reg(kCr1) = kCr1Ssi | kCr1Spe;
    reg(kCr1) = kCr1Ssi | kCr1Spe | kCr1Cstart;
}

// z's DAC to mid-scale (0 V), waiting for the frame: start and exit only.
void spi_dac_mid_scale() {
    spi_dac_start(0);
    spi_dac_finish();
}

}  // namespace

bool converter_axes_init(int axes) {
    if (axes < 2 || axes > 3 || g_timer_running) return false;
    {
        using namespace rcc;
        reg(kAhb4enr) = reg(kAhb4enr) | kAhb4GpioCEn | kAhb4GpioFEn | (axes == 3 ? kAhb4Adc3En : 0u);
        if (axes == 3) reg(kApb1lenr) = reg(kApb1lenr) | kApb1lSpi3En;
        const uint32_t readback = reg(kAhb4enr) | reg(kApb1lenr);
        (void)readback;
    }
    if (!adc_init(kAdcY)) return false;
    if (axes == 3 && !adc_init(kAdcZ)) return false;
    gpio::mode(gpio::kPortA, 5, gpio::kModeAnalog);
    reg(dac::kDhr12r2) = 2048;
    reg(dac::kCr) = reg(dac::kCr) | dac::kCrEn2;
    if (axes == 3) {
        spi_dac_init();
        spi_dac_mid_scale();
    }
    dcache_enable();
    g_converter_axes = axes;
    return true;
}

void init() {
    const bool clocks = clock_init();
    enable_clocks();
    // Without the PLL the APB1 clock is still HSI 64 MHz (reset prescalers).
    console_init(clocks ? config::kApb1Clock_Hz : 64'000'000u);
    dwt_init();
    if (!clocks) {
        const char msg[] = "fault clock: HSE or PLL1 not ready (is the ST-LINK MCO on PH0?); loop not started\n";
        console_write(msg, sizeof msg - 1);
        exit(kExitFault);
    }
    icache_enable();
    leds_init();
    // The stopwatch's own cost: two reads of CYCCNT around nothing.
    const uint32_t s = stopwatch_start();
    g_stopwatch_offset = stopwatch_elapsed(s);
    dac_init();
    const bool adc_ok = adc_init(kAdcX);
    // The serial number is in place before the device connects to the bus.
    g_usb_ready = stm32::usbfs::init(board_serial_number());
    if (!adc_ok) {
        const char msg[] = "fault adc: calibration or enable timed out\n";
        console_write(msg, sizeof msg - 1);
        exit(kExitFault);
    }
}

const char* board_serial_number() {
    // System memory, readable at any time; read once.
    if (g_serial[0] == '\0') g_serial = usb::serial_from_unique_id({reg(uid::kW0), reg(uid::kW1), reg(uid::kW2)});
    return g_serial.data();
}

void console_write(const char* text, std::size_t length) {
    if (!g_console_ready) return;
    for (std::size_t i = 0; i < length; ++i) {
        while ((reg(usart3::kIsr) & usart3::kIsrTxe) == 0u) {
        }
        reg(usart3::kTdr) = static_cast<uint8_t>(text[i]);
    }
    // Mirror to the USB link (dropped when the host is not reading).
    if (g_usb_ready && stm32::usbfs::configured())
        (void)stm32::usbfs::write(reinterpret_cast<const uint8_t*>(text), length);
}

bool console_read(char& c) {
    uint8_t b = 0;
    if (g_usb_ready && stm32::usbfs::read(&b, 1) == 1) {
        c = static_cast<char>(b);
        return true;
    }
    if (!g_console_ready || (reg(usart3::kIsr) & usart3::kIsrRxne) == 0u) return false;
    c = static_cast<char>(reg(usart3::kRdr) & 0xFFu);
    return true;
}

void exit(int status) {
    if (g_console_ready) {
        while ((reg(usart3::kIsr) & usart3::kIsrTc) == 0u) {
        }
    }
    tick_timer_stop();
    reg(dac::kDhr12r1) = 2048;  // 0 V command, on every axis
    if (g_converter_axes >= 2) reg(dac::kDhr12r2) = 2048;
    if (g_converter_axes == 3) spi_dac_mid_scale();
    gpio::set(gpio::kPortB, 14, status != 0);
    // Semihosting only with a debugger attached: without one, BKPT would
    // escalate to a HardFault.
    if ((scb::reg(scb::kDhcsr) & scb::kDhcsrDebugEnabled) != 0u) semihosting::exit(status);
    for (;;) asm volatile("wfi");
}

bool tick_timer_start(uint32_t rate_Hz, TickHandler handler) {
    if (rate_Hz == 0 || handler == nullptr || config::kTickTimerClock_Hz % rate_Hz != 0u) return false;
    const uint32_t period = config::kTickTimerClock_Hz / rate_Hz;
    if (period < 2u || period > 65536u) return false;
    tick_timer_stop();
    g_tick_handler = handler;
    using namespace tim6;
    reg(kPsc) = 0;
    reg(kArr) = period - 1u;
    reg(kCr2) = kCr2MmsUpdate;  // TRGO on update: starts the ADC conversion
    reg(kCr1) = kCr1Urs;        // only overflow sets UIF (not the UG below)
    reg(kEgr) = kEgrUg;         // load PSC/ARR now
    reg(kSr) = 0;
    reg(kDier) = kDierUie;
    for (int i = 0; i < g_converter_axes; ++i) reg(kAdcs[i] + adc::kIsr) = adc::kIsrEoc | adc::kIsrOvr;
    nvic::set_priority(config::kTickIrq, kTickPriority);
    nvic::clear_pending(config::kTickIrq);
    nvic::enable(config::kTickIrq);
    g_timer_running = true;
    reg(kCr1) = kCr1Urs | kCr1Cen;
    return true;
}

void tick_timer_stop() {
    using namespace tim6;
    reg(kCr1) = 0;
    reg(kDier) = 0;
    reg(kSr) = 0;
    nvic::disable(config::kTickIrq);
    nvic::clear_pending(config::kTickIrq);
    g_timer_running = false;
}

bool tick_timer_running() { return g_timer_running; }

void wait_for_interrupt() { asm volatile("dsb\n\twfi" ::: "memory"); }

void idle() {}

uint32_t timestamp() { return reg(core::kDwtCyccnt); }
uint32_t stopwatch_start() { return reg(core::kDwtCyccnt); }
uint32_t stopwatch_elapsed(uint32_t start) { return reg(core::kDwtCyccnt) - start - g_stopwatch_offset; }

EmulatedStage<fw::CoreSample>& emulated_stage() { return g_emulated_stage; }
void emulated_stage_step() {
    if (g_loopback) g_emulated_stage.step();
}
bool set_loopback(bool on) {
    if (g_timer_running) return false;  // the interrupt source follows the mode
    g_loopback = on;
    return true;
}

void set_led(Led led, bool on) { gpio::set(gpio::kPortB, led == Led::kHeartbeat ? 0 : 14, on); }

}  // namespace piezoloop::bsp

extern "C" void piezoloop_tick_timer_isr() noexcept {
    using namespace piezoloop::bsp;
    // Clear UIF first: an overrun re-pends the interrupt (then counted).
    stm32::reg(stm32::tim6::kSr) = 0;
    g_tick_handler();
}
