// The tick's I/O on the QEMU MPS2 boards: no converters, the emulated stage
// (bsp/emulated_stage.hpp) stands behind the controller's input and output,
// values passed in physical units exactly as host/sim passes them. Inline:
// part of the measured tick. Included through bsp/qemu-m*/board_io.hpp.
#pragma once

#include <cstdint>

#include "bsp/emulated_stage.hpp"

namespace piezoloop::bsp {

namespace mps2 {
extern fw::EmulatedStage g_emulated_stage;  // board.cpp
}  // namespace mps2

// Reading in, the pipeline's output phase, command out.
template <class T, class PipelineT>
inline void control_io(PipelineT& pipe) {
    fw::emulated_output<T>(pipe, mps2::g_emulated_stage);
}

}  // namespace piezoloop::bsp
