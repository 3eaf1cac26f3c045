// Start-up of every Cortex-M board: the vector table, the reset handler and
// the default exception handlers. Written for this project; no vendor
// startup file or CMSIS is used.
//
// Reset sequence:
//   1. the core loads SP from vector 0 (_estack) and jumps to vector 1;
//   2. Reset_Handler enables the FPU (CP10/CP11 full access) when the image
//      is built for one, before any compiled code could use an FP register;
//   3. piezoloop_start copies .data, zeroes .bss, points VTOR at our table,
//      runs static constructors, calls bsp::init() and app_main(), and hands
//      the result to bsp::exit().
#include <array>
#include <cstddef>
#include <cstdint>

#include "board_irqs.hpp"  // bsp/<board>/board_irqs.hpp: kIrqBindings
#include "bsp/bsp.hpp"
#include "bsp/cortex-m/scb.hpp"

using Handler = void (*)();

// Symbols from sections.ld.
extern "C" {
extern uint32_t _estack;
extern uint32_t _sidata, _sdata, _edata;
extern uint32_t _sbss, _ebss;
extern Handler __preinit_array_start[], __preinit_array_end[];
extern Handler __init_array_start[], __init_array_end[];

[[noreturn]] void Reset_Handler();
[[noreturn]] void piezoloop_start();

// Exception handlers (fault.cpp). Those without a fault meaning are weak
// aliases of piezoloop_default_handler there: define one to override it.
void piezoloop_default_handler() noexcept;
void NMI_Handler() noexcept;
void HardFault_Handler() noexcept;
void MemManage_Handler() noexcept;
void BusFault_Handler() noexcept;
void UsageFault_Handler() noexcept;
void SVC_Handler() noexcept;
void DebugMon_Handler() noexcept;
void PendSV_Handler() noexcept;
void SysTick_Handler() noexcept;
}

namespace {

// Exceptions 1..15 then the board's external interrupts. The layout is fixed
// by the architecture; `constinit` guarantees the table is built by the
// compiler (a table filled at run time would be empty at reset).
struct VectorTable {
    uint32_t* initial_sp;
    std::array<Handler, 15> exceptions;
    std::array<Handler, PIEZOLOOP_NUM_IRQ> irqs;
};

// Every line goes to the default handler except those the board binds.
// A binding outside the table is a compile error (constant evaluation of an
// out-of-range std::array index).
constexpr std::array<Handler, PIEZOLOOP_NUM_IRQ> board_irqs() {
    std::array<Handler, PIEZOLOOP_NUM_IRQ> table{};
    for (auto& h : table) h = piezoloop_default_handler;
    for (const auto& b : piezoloop::bsp::kIrqBindings) table.at(static_cast<std::size_t>(b.irq)) = b.handler;
    return table;
}

}  // namespace

// `used` + KEEP in sections.ld: nothing references the table by name.
__attribute__((section(".isr_vector"), used))
constinit const VectorTable piezoloop_vectors = {
    &_estack,
    {
        Reset_Handler,       // 1  reset
        NMI_Handler,         // 2  NMI
        HardFault_Handler,   // 3  hard fault
        MemManage_Handler,   // 4  memory management fault
        BusFault_Handler,    // 5  bus fault
        UsageFault_Handler,  // 6  usage fault
        nullptr,             // 7  reserved
        nullptr,             // 8  reserved
        nullptr,             // 9  reserved
        nullptr,             // 10 reserved
        SVC_Handler,         // 11 SVCall
        DebugMon_Handler,    // 12 debug monitor
        nullptr,             // 13 reserved
        PendSV_Handler,      // 14 PendSV
        SysTick_Handler,     // 15 SysTick
    },
    board_irqs(),
};

static_assert(sizeof(VectorTable) == (16 + PIEZOLOOP_NUM_IRQ) * sizeof(uint32_t),
              "vector table must be one word per entry");

// Naked: no prologue, so not a single compiler-generated instruction runs
// before CPACR grants FPU access (with -mfloat-abi=hard the compiler may use
// FP registers anywhere, even for integer copies). DSB/ISB make the new
// access rights visible before the next instruction (ARMv7-M ARM B3.2.20).
extern "C" __attribute__((naked, noreturn)) void Reset_Handler() {
    asm volatile(
#if defined(__ARM_FP)
        "movw r0, #0xED88\n\t"          // CPACR = 0xE000ED88
        "movt r0, #0xE000\n\t"
        "ldr  r1, [r0]\n\t"
        "orr  r1, r1, #(0xF << 20)\n\t"  // CP10, CP11: full access
        "str  r1, [r0]\n\t"
        "dsb\n\t"
        "isb\n\t"
#endif
        "b    piezoloop_start\n\t");
}

extern "C" [[noreturn]] void piezoloop_start() {
    // .data: copy the initial values from their load address.
    const uint32_t* src = &_sidata;
    for (uint32_t* dst = &_sdata; dst < &_edata;) *dst++ = *src++;
    // .bss: zero.
    for (uint32_t* dst = &_sbss; dst < &_ebss;) *dst++ = 0;

    // Exceptions and interrupts use our table even if a boot loader or the
    // boot address option bytes left VTOR elsewhere.
    piezoloop::bsp::scb::reg(piezoloop::bsp::scb::kVtor) =
        static_cast<uint32_t>(reinterpret_cast<uintptr_t>(&piezoloop_vectors));
    asm volatile("dsb\n\tisb" ::: "memory");

    // Static constructors (-nostartfiles: no crt0 / __libc_init_array).
    for (Handler* f = __preinit_array_start; f < __preinit_array_end; ++f) (*f)();
    for (Handler* f = __init_array_start; f < __init_array_end; ++f) (*f)();

    piezoloop::bsp::init();
    piezoloop::bsp::exit(app_main());
}

// Firmware never returns, so static destructors never run: registering them
// is a no-op. This keeps newlib's atexit machinery out of the image.
extern "C" {
void* __dso_handle = nullptr;
int __cxa_atexit(void (*)(void*), void*, void*) { return 0; }
}
