// What a board provides to the applications. The applications know nothing
// of registers; a board knows nothing of control (docs/architecture.md).
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

#include "app/core_sample.hpp"

namespace piezoloop {
template <class T>
class EmulatedStage;  // piezoloop/emulated_stage.hpp
}
namespace piezoloop::storage {
class ParamStorage;  // piezoloop/storage/param_storage.hpp
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

// The main loop found no work: let a little time pass before it looks again.
// On the QEMU boards a straight run of 500 NOPs, which QEMU executes far
// faster than a pass that polls the UART's registers, while the tick
// interrupt still lands on its exact instruction; the console is then read
// every 0.5 µs of board time. A no-op where time is real (STM32).
void idle();

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

// The tick's I/O is in bsp/<board>/board_io.hpp, inline (it sits inside
// the measured tick):
//   template <class T, class PipelineT> void control_io(PipelineT& pipe);
// reads the controller's input, runs pipe.output() (the tick's output phase;
// firmware/app/control_loop.cpp runs begin_tick() before and end_tick()
// after it) and writes its output.
// Hardware (STM32): ADC code -> sample -> output -> sample -> DAC code, 16-bit
// two's-complement codes spanning [-full scale, +full scale) of
// config::kPositionFullScale_um / config::kVoltageFullScale_V
// (bsp/converter16.hpp; adc_read() / dac_write() are the raw converters).
// Boards without converters (QEMU), and the STM32 in loopback: the emulated
// stage's reading and command in physical units, exactly as host/sim passes
// them (common/piezoloop/emulated_stage.hpp).

// The emulated stage (StageModel, the simulator's float stage) whose reading
// the next tick uses. emulated_stage_step() advances it by one sample (the
// physics between this tick's output and the next tick's input); it does
// nothing where the converters are real and loopback is off.
EmulatedStage<fw::CoreSample>& emulated_stage();
void emulated_stage_step();
// Hardware boards: route adc_read/dac_write to the emulated stage (self-test
// without a stage attached). Boards without converters are always in
// loopback and refuse false.
bool set_loopback(bool on);

// ---- parameter storage --------------------------------------------------------

// Where the board keeps its commissioned parameter set, or null where it
// has none. QEMU boards: a host file through semihosting, named by the
// `--storage=PATH` argument of the semihosting command line (`piezoloop
// emulate --storage FILE`; bsp/mps2/semihosting_storage.cpp); null without
// one. STM32H743: the last flash sector of bank 2
// (bsp/stm32h743/flash_storage.cpp). Main loop only; the first call sets
// the backend up.
storage::ParamStorage* param_storage();

}  // namespace piezoloop::bsp

// The application's entry point, called by the startup code. Not `main`:
// C++ forbids calling main from the program.
int app_main();
