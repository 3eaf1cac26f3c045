// The tick's I/O on the QEMU MPS2 boards: no converters, the emulated stage
// (common/piezoloop/emulated_stage.hpp) stands behind the controller's input and output,
// values passed in physical units exactly as host/sim passes them. Inline:
// part of the measured tick. Included through bsp/qemu-m*/board_io.hpp.
#pragma once

#include <cstdint>

#include "app/core_sample.hpp"
#include "piezoloop/emulated_stage.hpp"

namespace piezoloop::bsp {

namespace mps2 {
extern EmulatedStage<fw::CoreSample> g_emulated_stage;  // board.cpp
}  // namespace mps2

// Reading in, the pipeline's output phase, command out.
template <class T, class PipelineT>
inline void control_io(PipelineT& pipe) {
    mps2::g_emulated_stage.output(pipe);
}

}  // namespace piezoloop::bsp
