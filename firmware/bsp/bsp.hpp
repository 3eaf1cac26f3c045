// What a board provides to the applications. The applications know nothing
// of registers; a board knows nothing of control (DESIGN.md).
//
// Start-up order (bsp/cortex-m/startup.cpp): FPU on, .data copied, .bss
// zeroed, static constructors run, then bsp::init(), then app_main(); its
// return value goes to bsp::exit().
#pragma once

#include <cstddef>

namespace piezoloop::bsp {

// PIEZOLOOP_BOARD as configured ("qemu-m7", "qemu-m3", "stm32h743").
inline constexpr const char* kBoardName = PIEZOLOOP_BOARD_NAME;

// Board bring-up after RAM is initialised: clocks and the console.
void init();

// Blocking, polled console output (UART). Safe to call from fault handlers.
void console_write(const char* text, std::size_t length);

// End of the program. Status 0 is success. QEMU boards leave the emulator
// through semihosting with this exit status; hardware halts (or reports to
// an attached debugger).
[[noreturn]] void exit(int status);

// Exit statuses used by the BSP itself (applications use 0 and small counts).
inline constexpr int kExitFault = 100;            // a fault handler ran
inline constexpr int kExitUnexpectedIrq = 101;    // an interrupt nobody handles

}  // namespace piezoloop::bsp

// The application's entry point, called by the startup code. Not `main`:
// C++ forbids calling main from the program.
int app_main();
