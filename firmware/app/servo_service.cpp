#include "app/servo_service.hpp"

#include "board_config.hpp"
#include "bsp/cortex-m/semihosting.hpp"

#ifndef PIEZOLOOP_VERSION
#define PIEZOLOOP_VERSION "0.0.0"
#endif

namespace piezoloop::fw {

namespace {

ServiceLoop g_service;
uint32_t g_saved_primask = 0;

// The emulated boards' serial: fixed per image (they have no unique ID).
// A board with one (STM32) defines PIEZOLOOP_BOARD_UNIQUE_SERIAL and
// bsp::board_serial_number() in its board_config.hpp.
constexpr const char* board_serial() {
    const char* b = bsp::kBoardName;
    if (b[0] == 'q' && b[5] == 'm' && b[6] == '7') return "QEMU-M7-0001";
    if (b[0] == 'q' && b[5] == 'm' && b[6] == '3') return "QEMU-M3-0001";
    return "STM32H743-0001";
}

}  // namespace

ServiceLoop& service_loop() { return g_service; }

void semihosting_note(const char* a, const char* b, const char* c, const char* d) {
    if constexpr (!bsp::config::kHasConverters) {
        for (const char* s : {a, b, c, d})
            if (s != nullptr && s[0] != '\0') (void)bsp::semihosting::call(0x04, s);  // SYS_WRITE0
        (void)bsp::semihosting::call(0x04, "\n");
    }
}

// Masks the tick interrupt (PRIMASK) around main-loop changes the tick
// reads. A masked section starts right after a tick has run, so it has a
// whole period before the next tick is due (plus half a period before a
// delayed tick counts as missed): StartWave's section configures the wave
// generator, which on the soft-float Cortex-M3 takes thousands of
// instructions.
void mask_tick(bool masked) {
    if (masked) {
        const uint32_t t = g_service.ticks();
        while (g_service.running() && g_service.ticks() == t) {
        }
        uint32_t p;
        asm volatile("mrs %0, primask\n\tcpsid i" : "=r"(p)::"memory");
        g_saved_primask = p;
    } else {
        asm volatile("msr primask, %0" ::"r"(g_saved_primask) : "memory");
    }
}

link::DeviceInfo device_info() {
    link::DeviceInfo info;
    info.board = bsp::kBoardName;
    info.firmware_version = PIEZOLOOP_VERSION;
#ifdef PIEZOLOOP_BOARD_UNIQUE_SERIAL
    info.serial = bsp::board_serial_number();  // STM32: the unique ID, as the USB serial number
#else
    info.serial = board_serial();
#endif
    return info;
}

link::TickStats tick_stats() {
    const LoopStatus st = g_service.status();
    link::TickStats t;
    t.overruns = st.late + st.missed;
    t.time_min = st.control.min;
    t.time_max = st.control.max;
    t.time_mean = static_cast<float>(st.control.mean_tenths()) / 10.0f;
    // Instructions on the QEMU boards (no time base), cycles on hardware.
    t.counter_Hz = bsp::config::kHasConverters ? static_cast<float>(bsp::config::kCpuClock_Hz) : 0.0f;
    t.board_faults = g_service.board_faults;
    return t;
}

void send_frame(std::span<const uint8_t> frame) {
    bsp::console_write(reinterpret_cast<const char*>(frame.data()), frame.size());
}

// The heartbeat toggles every 0.5 s of ticks (so it stops when the loop
// stops), the fault LED shows a tripped output limiter.
void update_leds(uint32_t& last_toggle, bool& on) {
    const uint32_t t = g_service.ticks();
    if (t - last_toggle >= g_service.rate_Hz / 2) {
        on = !on;
        last_toggle = t;
        bsp::set_led(bsp::Led::kHeartbeat, on);
    }
    bsp::set_led(bsp::Led::kFault, g_service.tripped());
}

}  // namespace piezoloop::fw
