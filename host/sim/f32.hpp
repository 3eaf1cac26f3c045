// A double setting as the float the core's blocks are configured with.
#pragma once

namespace piezoloop::sim {

inline float f32(double x) { return static_cast<float>(x); }

}  // namespace piezoloop::sim
