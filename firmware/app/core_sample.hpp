// The sample type the control core runs on this board, chosen per board in
// bsp/<board>/board.cmake (PIEZOLOOP_FW_SAMPLE): float on the Cortex-M7
// boards (hardware FPU), Q31 on the Cortex-M3 (no FPU).
#pragma once

#include "piezoloop/q31.hpp"
#include "piezoloop/sample.hpp"

namespace piezoloop::fw {

#if PIEZOLOOP_FW_SAMPLE_Q31
using CoreSample = Q31;
inline constexpr const char* kCoreSampleName = "q31";
#else
using CoreSample = float;
inline constexpr const char* kCoreSampleName = "float";
#endif

static_assert(is_sample_type_v<CoreSample>);

}  // namespace piezoloop::fw
