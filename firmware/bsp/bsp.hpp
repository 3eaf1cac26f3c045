// What a board provides to the applications. The applications know nothing
// of registers; a board knows nothing of control (DESIGN.md).
//
// Start-up order (bsp/cortex-m/startup.cpp): FPU on, .data copied, .bss
// zeroed, static constructors run, then bsp::init(), then app_main(); its
// return value goes to bsp::exit().
//
// Board constants (clock, converter full scales, hard output limits, the
// unit of the stopwatch) are in bsp/<board>/board_config.hpp, included as
// "board_config.hpp" (the board's directory is on the include path).
#pragma once

#include <cstddef>
#include <cstdint>

namespace piezoloop::fw {
class EmulatedStage;  // bsp/emulated_stage.hpp
}

namespace piezoloop::bsp {

// PIEZOLOOP_BOARD as configured ("qemu-m7", "qemu-m3", "stm32h743").
inline constexpr const char* kBoardName = PIEZOLOOP_BOARD_NAME;

// Board bring-up after RAM is initialised: clocks, the console, the
// timestamp counter. The control timer stays off until tick_timer_start().
void init();

// Blocking, polled console output (UART). Safe to call from fault handlers.
void console_write(const char* text, std::size_t length);

// Non-blocking console input: true and the byte in c if one was received.
bool console_read(char& c);

// End of the program. Status 0 is success. QEMU boards leave the emulator
// through semihosting with this exit status; hardware halts (or reports to
// an attached debugger).
[[noreturn]] void exit(int status);

// Exit statuses used by the BSP itself (applications use 0 and small counts).
inline constexpr int kExitFault = 100;            // a fault handler ran
inline constexpr int kExitUnexpectedIrq = 101;    // an interrupt nobody handles

// ---- the control loop's hardware --------------------------------------------

// The periodic control interrupt. handler runs in interrupt context once per
// period, at the highest priority used by the firmware. rate_Hz must divide
// the timer clock (config::kTickTimerClock_Hz) into a whole number of counts;
// returns false (and starts nothing) otherwise. The interrupt flag is
// cleared before handler is called.
using TickHandler = void (*)();
bool tick_timer_start(uint32_t rate_Hz, TickHandler handler);
// Stops the timer; safe from the handler itself (the current tick finishes,
// no further one starts). A pending request is discarded.
void tick_timer_stop();
bool tick_timer_running();

// Status LEDs (NUCLEO: LD1 green, LD3 red; MPS2: FPGA LEDs 0 and 1).
enum class Led : uint8_t { kHeartbeat, kFault };
void set_led(Led led, bool on);

// Idle until an interrupt (WFI) where that keeps time; a no-op on the QEMU
// boards, whose main loops busy-poll: QEMU 7.2 under -icount sleep=off
// skips every other 100 kHz timer period while the core sleeps (seen as a
// 20 µs tick spacing on SysTick), whereas executing keeps it exact. Call
// with interrupts masked after checking for work; a pending interrupt
// still ends the wait.
void wait_for_interrupt();

// Free-running timestamp counter: counts up at config::kTimestamp_Hz and
// wraps modulo config::kTimestampMask + 1. Differences are taken masked.
uint32_t timestamp();

// Execution time of a code region, in config::kWorkUnit ("insn" on the QEMU
// boards: instructions under -icount shift=0; "cycles" on hardware: DWT
// CYCCNT), with resolution config::kStopwatchResolution. The overhead of
// the two calls is calibrated out. Usable in interrupt context.
//   const uint32_t s = bsp::stopwatch_start();  ...  n = bsp::stopwatch_elapsed(s);
uint32_t stopwatch_start();
uint32_t stopwatch_elapsed(uint32_t start);

// The converters of the tick are in bsp/<board>/board_io.hpp, inline (they
// sit inside the measured tick):
//   int32_t adc_read();          the displacement sensor's latest sample
//   void dac_write(int32_t code);  the amplifier's input
// 16-bit two's-complement codes in [-32768, 32767] spanning [-full scale,
// +full scale) of config::kPositionFullScale_um (ADC) and
// config::kVoltageFullScale_V (DAC, referred to the piezo voltage); see
// bsp/converter16.hpp.

// Boards without converters (QEMU) connect the DAC to an emulated stage,
// the plant model of common/, whose displacement the next adc_read()
// returns. emulated_stage_step() advances that plant by one sample (the
// physics between this DAC write and the next ADC sample); it does nothing
// where the converters are real and loopback is off.
fw::EmulatedStage& emulated_stage();
void emulated_stage_step();
// Hardware boards: route adc_read/dac_write to the emulated stage (self-test
// without a stage attached). Boards without converters are always in
// loopback and refuse false.
bool set_loopback(bool on);

}  // namespace piezoloop::bsp

// The application's entry point, called by the startup code. Not `main`:
// C++ forbids calling main from the program.
int app_main();
