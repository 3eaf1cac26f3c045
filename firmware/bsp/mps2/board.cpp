// Board support shared by the two QEMU MPS2 boards (mps2-an385 Cortex-M3,
// mps2-an500 Cortex-M7): console on CMSDK UART0, exit through semihosting,
// the control tick on CMSDK TIMER0, SysTick as timestamp counter and
// instruction stopwatch, and the emulated stage behind the "converters".
// Both FPGA images put UART0 at 0x40004000, TIMER0 at 0x40000000 (IRQ 8)
// and clock the APB at 25 MHz (AN385/AN500; QEMU hw/arm/mps2.c SYSCLK_FRQ).
#include "board_config.hpp"
#include "board_io.hpp"
#include "bsp/bsp.hpp"
#include "bsp/cortex-m/nvic.hpp"
#include "bsp/cortex-m/semihosting.hpp"
#include "bsp/cortex-m/systick.hpp"
#include "bsp/mps2/cmsdk_timer.hpp"
#include "bsp/mps2/cmsdk_uart.hpp"
#include "piezoloop/emulated_stage.hpp"

namespace piezoloop::bsp {

namespace mps2 {
EmulatedStage<fw::CoreSample> g_emulated_stage;
}  // namespace mps2

namespace {
constexpr mps2::CmsdkUart kUart0{0x40004000};
constexpr mps2::CmsdkTimer kTimer0{0x40000000};
constexpr uint32_t kConsoleBaud = 115'200;
// The tick preempts everything else the firmware runs (the main loop only).
constexpr uint8_t kTickPriority = 0x00;

TickHandler g_tick_handler = nullptr;
int32_t g_stopwatch_offset = 0;

}  // namespace

// The stopwatch's own cost, calls included, measured through the public
// functions (offset still 0) on regions of J = 0..3 NOPs, each preceded by
// a phase shift of k = 0..39 passes of a 3-instruction loop. The error of
// one measurement depends on the phase of the start relative to the
// SysTick edge (modulo the 3-instruction start spin) and of the stop
// (modulo the 4-instruction stop spin); shifting the start through all 40
// phases and the stop through 4 lengths makes both uniform, so the mean of
// (measured - J) is the unbiased offset.
template <int J>
__attribute__((always_inline)) inline int32_t calibration_sample(uint32_t shift) {
    asm volatile(
        "1:\n\t"
        "subs %0, %0, #1\n\t"
        "nop\n\t"
        "bpl  1b\n\t"
        : "+r"(shift)::"cc");
    const uint32_t s = stopwatch_start();
    if constexpr (J >= 1) asm volatile("nop");
    if constexpr (J >= 2) asm volatile("nop");
    if constexpr (J >= 3) asm volatile("nop");
    return static_cast<int32_t>(stopwatch_elapsed(s)) - J;
}

__attribute__((noinline)) static int32_t calibrate_stopwatch() {
    int32_t sum = 0, n = 0;
    for (uint32_t k = 0; k < 40; ++k) {
        sum += calibration_sample<0>(k) + calibration_sample<1>(k) + calibration_sample<2>(k) +
               calibration_sample<3>(k);
        n += 4;
    }
    return (sum + n / 2) / n;
}

void init() {
    kUart0.enable_tx(config::kCpuClock_Hz, kConsoleBaud);
    kUart0.enable_rx();
    kTimer0.stop();
    systick::start_free_running();
    g_stopwatch_offset = calibrate_stopwatch();
}

void console_write(const char* text, std::size_t length) {
    for (std::size_t i = 0; i < length; ++i) kUart0.put(text[i]);
}

bool console_read(char& c) { return kUart0.try_get(c); }

void exit(int status) {
    // QEMU is always run with -semihosting for these boards.
    semihosting::exit(status);
    for (;;) asm volatile("wfi");
}

bool tick_timer_start(uint32_t rate_Hz, TickHandler handler) {
    if (rate_Hz == 0 || handler == nullptr || config::kTickTimerClock_Hz % rate_Hz != 0u) return false;
    const uint32_t period = config::kTickTimerClock_Hz / rate_Hz;
    if (period < 2u) return false;
    tick_timer_stop();
    g_tick_handler = handler;
    nvic::set_priority(config::kTickIrq, kTickPriority);
    kTimer0.start_periodic(period);
    nvic::clear_pending(config::kTickIrq);
    nvic::enable(config::kTickIrq);
    return true;
}

void tick_timer_stop() {
    kTimer0.stop();
    nvic::disable(config::kTickIrq);
    nvic::clear_pending(config::kTickIrq);
}

bool tick_timer_running() { return kTimer0.running(); }

void wait_for_interrupt() {}  // busy-poll: see bsp.hpp

void idle() { asm volatile(".rept 500\n\tnop\n\t.endr" ::: "memory"); }

// FPGAIO (0x40028000) LED register: bit 0 LED0, bit 1 LED1.
// The register is written only when a LED changes: the main loop sets both
// every pass, and each register access costs QEMU far more than an
// instruction.
void set_led(Led led, bool on) {
    static uint32_t shown = 0;
    const uint32_t bit = led == Led::kHeartbeat ? 1u : 2u;
    const uint32_t next = on ? (shown | bit) : (shown & ~bit);
    if (next == shown) return;
    shown = next;
    *reinterpret_cast<volatile uint32_t*>(uintptr_t{0x40028000}) = next;
}

uint32_t timestamp() { return systick::up_count(); }

uint32_t stopwatch_start() { return systick::sync_to_edge(); }

uint32_t stopwatch_elapsed(uint32_t start) {
    const int32_t n = systick::raw_elapsed(start, systick::read_stop()) - g_stopwatch_offset;
    return n < 0 ? 0u : static_cast<uint32_t>(n);  // only while calibrating can n be < 0
}

EmulatedStage<fw::CoreSample>& emulated_stage() { return mps2::g_emulated_stage; }
void emulated_stage_step() { mps2::g_emulated_stage.step(); }
bool set_loopback(bool on) { return on; }  // no real converters: always emulated

}  // namespace piezoloop::bsp

extern "C" void piezoloop_tick_timer_isr() noexcept {
    using namespace piezoloop::bsp;
    // Cleared first: if the tick overruns its period, the flag is set again
    // and the interrupt re-enters right after this one (counted as overrun
    // by the application's tick monitor, never lost silently).
    kTimer0.clear_interrupt();
    g_tick_handler();
}
