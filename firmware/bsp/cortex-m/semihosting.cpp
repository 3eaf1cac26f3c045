#include "bsp/cortex-m/semihosting.hpp"

namespace piezoloop::bsp::semihosting {

uint32_t call(uint32_t operation, const void* argument) {
    uint32_t result;
    // Operation in r0, argument in r1, result back in r0. The host may read
    // the memory behind r1 (and for some operations write it): "memory".
    asm volatile(
        "mov r0, %[op]\n\t"
        "mov r1, %[arg]\n\t"
        "bkpt 0xAB\n\t"
        "mov %[res], r0"
        : [res] "=r"(result)
        : [op] "r"(operation), [arg] "r"(argument)
        : "r0", "r1", "memory");
    return result;
}

void exit(int status) {
    if (status == 0) {
        // On AArch32, r1 holds the reason itself, not a pointer to a block.
        call(kSysExit, reinterpret_cast<const void*>(uintptr_t{kApplicationExit}));
        return;
    }
    const uint32_t block[2] = {kApplicationExit, static_cast<uint32_t>(status)};
    call(kSysExitExtended, block);
    call(kSysExit, reinterpret_cast<const void*>(uintptr_t{kRunTimeErrorUnknown}));
}

}  // namespace piezoloop::bsp::semihosting
