// servo_xyz.elf's axes: three axes on the board's own converters
// (bsp/<board>/board_io.hpp, ConverterAxes), every axis with the board's
// full scales and hard limits per actuator channel, at the board's loop
// rate; the pipeline and its link device in the board's bulk RAM
// (.axisram, bsp/<board>/memory.ld). Built only for boards whose
// board.cmake sets PIEZOLOOP_XYZ_IMAGE.
#include <cstddef>
#include <new>

#include "app/axes_service.hpp"
#include "app/servo_axes.hpp"
#include "board_config.hpp"
#include "board_io.hpp"

namespace piezoloop::fw {

namespace {

constexpr int kAxes = PIEZOLOOP_BOARD_CONVERTER_AXES;
[[gnu::section(".axisram")]] alignas(AxesPipe<kAxes>) unsigned char g_pipe_storage[sizeof(AxesPipe<kAxes>)];
[[gnu::section(".axisram")]] alignas(AxesDevice<kAxes>) unsigned char g_device_storage[sizeof(AxesDevice<kAxes>)];
bsp::ConverterAxes<kAxes> g_converters;

}  // namespace

int run_servo_converter_axes(link::DeviceHooks hooks) {
    if (!bsp::converter_axes_init(kAxes)) return 1;
    // The startup does not clear .axisram.
    __builtin_memset(g_pipe_storage, 0, sizeof g_pipe_storage);
    __builtin_memset(g_device_storage, 0, sizeof g_device_storage);
    MultiAxisSetup<kAxes> setup{};
    for (std::size_t k = 0; k < static_cast<std::size_t>(kAxes); ++k) {
        setup.axes[k] = pipeline_setup(board_analog());
        setup.channels[k] = bsp::config::kHardLimits;
    }
    AxesPipe<kAxes>& pipe = *new (g_pipe_storage) AxesPipe<kAxes>(setup);
    if (!pipe.setup_status().ok()) return 1;
    return serve_axes<kAxes>(pipe, g_converters, g_device_storage, kLoopRateInt_Hz, hooks);
}

}  // namespace piezoloop::fw
