// The servo image on a stage of 2 or 3 coupled axes (emulated boards): the
// emulation profile's axis 0 and the axes blob's further axes and coupling
// paths (common/piezoloop/axes/emulation_axes_profile.hpp) become a
// MultiAxisPipeline of that many axes, each empty (the host configures
// it), against the emulated coupled stage, with the link device on the N
// axes (link/device.hpp) and the tick of app/axes_loop.hpp.
#pragma once

#include <cstdint>
#include <span>

#include "piezoloop/emulation_profile.hpp"
#include "piezoloop/link/device.hpp"
#include "piezoloop/status.hpp"

namespace piezoloop::fw {

// Decodes and validates the axes blob against its profile and this board
// (at most kSelfTestAxes axes: as many as its self-test runs); kept for
// run_servo_axes. Errors name the field ("axes", "axis[1].plant", ...).
Status check_axes_profile(std::span<const uint8_t> blob, const EmulationProfile& first);

// Builds the axes of the checked blob, loads the stored set, starts the
// tick at the profile's rate and serves the link; returns (non-zero) only
// if the axes cannot run. hooks: mask_tick and storage (the stage's
// restart is added here).
int run_servo_axes(const EmulationProfile& first, link::DeviceHooks hooks);

// servo_xyz.elf, on a board with converters for three axes (the
// STM32H743; app/servo_converter_axes.cpp, built into that image only):
// starts the further converters, builds the axes with the board's full
// scales and hard limits, loads the stored set, starts the tick and serves
// the link; returns (non-zero) only if the axes cannot run.
int run_servo_converter_axes(link::DeviceHooks hooks);

}  // namespace piezoloop::fw
