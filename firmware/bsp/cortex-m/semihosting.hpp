// ARM semihosting (the "Semihosting for AArch32 and AArch64" specification,
// v2): a BKPT 0xAB on M-profile hands an operation in r0, with its argument
// in r1, to the debugger or emulator (qemu-system-arm -semihosting).
//
// Only valid when something services it: under QEMU with -semihosting, or
// with a debugger attached. Without one, BKPT escalates to a HardFault.
#pragma once

#include <cstdint>

namespace piezoloop::bsp::semihosting {

inline constexpr uint32_t kSysExit = 0x18;          // SYS_EXIT (angel_SWIreason_ReportException)
inline constexpr uint32_t kSysExitExtended = 0x20;  // SYS_EXIT_EXTENDED (v2.0)

// Reasons of SYS_EXIT (ADP_Stopped_*).
inline constexpr uint32_t kApplicationExit = 0x20026;     // ADP_Stopped_ApplicationExit
inline constexpr uint32_t kRunTimeErrorUnknown = 0x20023; // ADP_Stopped_RunTimeErrorUnknown

// Performs one semihosting call and returns r0.
uint32_t call(uint32_t operation, const void* argument);

// Ends the session with an exit status. Status 0 is the classic 32-bit
// SYS_EXIT with ADP_Stopped_ApplicationExit (QEMU exits 0). Any other status
// uses SYS_EXIT_EXTENDED {ApplicationExit, status}, which QEMU turns into
// that process exit status; if the host does not implement it, falls back
// to SYS_EXIT with RunTimeErrorUnknown (QEMU exits 1). Returns only if no
// host serviced the call.
void exit(int status);

}  // namespace piezoloop::bsp::semihosting
