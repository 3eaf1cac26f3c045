// The link service of a board of N axes, shared by its two sources of
// readings: the emulated coupled stage (app/servo_axes.cpp) and the board's
// own converters (app/servo_converter_axes.cpp). The service loop's view of
// the axes' tick, the link device built in place, the stored set, then the
// tick of app/axes_loop.hpp and the link served for good.
#pragma once

#include <cstdint>
#include <new>

#include "app/axes_loop.hpp"
#include "app/servo_service.hpp"
#include "piezoloop/link/device.hpp"

namespace piezoloop::fw {

inline uint32_t axes_loop_ticks() { return __atomic_load_n(&axes_loop().ticks, __ATOMIC_RELAXED); }
inline bool axes_loop_running() { return axes_loop().running; }

template <int N>
bool axes_loop_tripped() {
    const AxesPipe<N>& pipe = *static_cast<const AxesPipe<N>*>(axes_loop().pipe);
    for (int i = 0; i < N; ++i)
        if (pipe.axis(i).limiter().tripped()) return true;
    return false;
}

// Serves N axes against `io` (output(pipe) and step(), app/axes_loop.hpp)
// at rate_Hz; the device is built in device_storage. Returns (1) only if
// the tick cannot start.
template <int N, class Io>
int serve_axes(AxesPipe<N>& pipe, Io& io, void* device_storage, uint32_t rate_Hz, link::DeviceHooks hooks) {
    axes_loop().pipe = &pipe;
    axes_loop().stage = &io;
    // Before the stored set: its load masks the tick (mask_tick).
    ServiceLoop& svc = service_loop();
    svc.ticks = &axes_loop_ticks;
    svc.running = &axes_loop_running;
    svc.status = &axes_loop_status;
    svc.tripped = &axes_loop_tripped<N>;
    AxesDevice<N>& dev = *new (device_storage) AxesDevice<N>(pipe, device_info(), hooks);
    (void)load_stored_set(dev);
    if (!start_axes_loop<N>(pipe, io, &dev, rate_Hz, 0, TickTiming::kControlOnly)) return 1;
    serve(dev);
}

}  // namespace piezoloop::fw
