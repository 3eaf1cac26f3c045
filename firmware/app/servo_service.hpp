// The servo image's link service, whichever tick runs: the single-axis
// ControlLoop (app/control_loop.hpp) or the loop of coupled axes
// (app/axes_loop.hpp). The main loop serves the binary link protocol
// (docs/protocol.md) on the console UART and drives the LEDs; what it needs
// of the running loop is ServiceLoop, filled in before serve().
#pragma once

#include <array>
#include <cstddef>
#include <cstdint>
#include <span>

#include "app/control_loop.hpp"
#include "bsp/bsp.hpp"
#include "piezoloop/link/device.hpp"

namespace piezoloop::fw {

struct ServiceLoop {
    uint32_t rate_Hz = kLoopRateInt_Hz;
    // Board fault bits of the status reply (TickStats::board_faults,
    // shifted to faults bit 8 and up).
    uint32_t board_faults = 0;
    uint32_t (*ticks)() = nullptr;     // ticks since the loop started
    bool (*running)() = nullptr;
    LoopStatus (*status)() = nullptr;  // a consistent copy of the figures
    bool (*tripped)() = nullptr;       // an output limiter tripped (the fault LED)
};
ServiceLoop& service_loop();

// Board fault bit 0: the emulation profile (or its axes) was rejected.
inline constexpr uint32_t kFaultProfileInvalid = 1u << 0;

// Text on the semihosting console (QEMU's stdout/stderr, never the UART);
// nothing on boards with converters.
void semihosting_note(const char* a, const char* b = "", const char* c = "", const char* d = "");

// The link hooks: the tick masked around main-loop changes it reads.
void mask_tick(bool masked);

// Board name, firmware version and serial for Hello.
link::DeviceInfo device_info();

// The tick figures for a status reply.
link::TickStats tick_stats();

void send_frame(std::span<const uint8_t> frame);
void update_leds(uint32_t& last_toggle, bool& on);

// One 0x00 delimiter (a client's decoder starts in sync), then the link
// for good.
inline constexpr uint32_t kMaxIdles = 16;

template <class Device>
[[noreturn]] void serve(Device& dev) {
    const char sync = 0;
    bsp::console_write(&sync, 1);
    uint32_t last_toggle = 0;
    bool heartbeat = false;
    std::array<uint8_t, 64> rx{};
    uint32_t quiet_passes = 0;  // passes in a row that found no work
    for (;;) {
        update_leds(last_toggle, heartbeat);
        std::size_t n = 0;
        char c = 0;
        while (n < rx.size() && bsp::console_read(c)) rx[n++] = static_cast<uint8_t>(c);
        if (n != 0) {
            dev.set_tick_stats(tick_stats());  // fresh for a status request
            dev.receive(std::span<const uint8_t>(rx.data(), n), send_frame);
        }
        // Every pass, so log blocks stream as the recorder fills.
        const bool sent = dev.poll_log(send_frame);
        // A quiet link is looked at less and less often, down to every
        // kMaxIdles idles; any byte or block brings the next look at once.
        if (n != 0 || sent) {
            quiet_passes = 0;
        } else {
            if (quiet_passes < kMaxIdles) ++quiet_passes;
            for (uint32_t i = 0; i < quiet_passes; ++i) bsp::idle();
        }
    }
}

// The stored set (Load at boot), its outcome noted on the semihosting
// console; the state.
template <class Device>
link::StorageState load_stored_set(Device& dev) {
    const link::StorageState st = dev.boot_from_storage();
    if (st != link::StorageState::kAbsent) {
        const link::StatusReply why = dev.make_status();
        semihosting_note("piezoloop: stored parameter set ", link::storage_state_name(st), " ", why.storage_field.data());
    }
    return st;
}

}  // namespace piezoloop::fw
