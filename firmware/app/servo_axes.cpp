#include "app/servo_axes.hpp"

#include <array>
#include <new>
#include <utility>

#include "app/axes_loop.hpp"
#include "app/axes_service.hpp"
#include "app/servo_service.hpp"
#include "board_config.hpp"
#include "piezoloop/axes/emulation_axes_profile.hpp"

namespace piezoloop::fw {

namespace {

constexpr int kServoAxes = bsp::config::kSelfTestAxes;
constexpr int kLargest = kServoAxes >= 2 ? kServoAxes : 2;

// Raw storage for the largest count, built in place for the profile's
// (no static constructors: an image without axes keeps none of it).
alignas(AxesPipe<kLargest>) unsigned char g_pipe_storage[kServoAxes >= 2 ? sizeof(AxesPipe<kLargest>) : 1];
alignas(AxesStage<kLargest>) unsigned char g_stage_storage[kServoAxes >= 2 ? sizeof(AxesStage<kLargest>) : 1];
alignas(AxesDevice<kLargest>) unsigned char g_device_storage[kServoAxes >= 2 ? sizeof(AxesDevice<kLargest>) : 1];
alignas(EmulationAxesProfile) unsigned char g_axes_storage[sizeof(EmulationAxesProfile)];
alignas(CoupledStage) unsigned char g_scratch_storage[sizeof(CoupledStage)];  // 9 KiB: not on the boot stack
EmulationAxesProfile* g_axes = nullptr;
void (*g_restart)() = nullptr;

template <int N>
void restart_stage_n() {
    static_cast<AxesStage<N>*>(axes_loop().stage)->reset();
}
bool restart_stage() {
    g_restart();
    return true;
}

template <int N>
int run(const EmulationProfile& first, link::DeviceHooks hooks) {
    const auto rate_Hz = static_cast<float>(first.loop_rate_Hz);
    MultiAxisSetup<N> setup{};
    std::array<SignalScale, N> position{}, voltage{};
    for (int i = 0; i < N; ++i) {
        const std::size_t k = static_cast<std::size_t>(i);
        setup.axes[k] = pipeline_setup(BoardAnalog{bsp::config::kHardLimits, g_axes->position_full_scale_um[k],
                                                   g_axes->voltage_full_scale_V[k]},
                                       rate_Hz);
        setup.channels[k] = bsp::config::kHardLimits;
        position[k] = setup.axes[k].position;
        voltage[k] = setup.axes[k].voltage;
    }
    AxesPipe<N>& pipe = *new (g_pipe_storage) AxesPipe<N>(setup);
    if (!pipe.setup_status().ok()) return 1;
    AxesStage<N>& stage = *new (g_stage_storage) AxesStage<N>();
    if (!stage.configure(g_axes->stage, position, voltage).ok()) return 1;
    g_restart = &restart_stage_n<N>;
    hooks.restart_stage = &restart_stage;
    return serve_axes<N>(pipe, stage, g_device_storage, first.loop_rate_Hz, hooks);
}

}  // namespace

Status check_axes_profile(std::span<const uint8_t> blob, const EmulationProfile& first) {
    auto* p = new (g_axes_storage) EmulationAxesProfile();
    auto* scratch = new (g_scratch_storage) CoupledStage();
    if (const Status s = decode_axes_profile(blob, first, *p, *scratch); !s.ok()) return s;
    if (p->axes > kServoAxes)
        return error("axes", kServoAxes >= 3 ? "must be at most 3 on this board"
                                             : "must be at most 2 on this board (3 axes: qemu-m7)");
    g_axes = p;
    return ok_status();
}

int run_servo_axes(const EmulationProfile& first, link::DeviceHooks hooks) {
    if constexpr (kServoAxes >= 2) {
        if (g_axes == nullptr) return 1;
        if (g_axes->axes == 2) return run<2>(first, hooks);
        if constexpr (kServoAxes >= 3)
            if (g_axes->axes == 3) return run<3>(first, hooks);
    }
    (void)first;
    (void)hooks;
    return 1;
}

}  // namespace piezoloop::fw
