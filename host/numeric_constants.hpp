// The mathematical constants the host code shares, in double.
#pragma once

#include <limits>
#include <numbers>

namespace piezoloop {

inline constexpr double kTwoPi = 2.0 * std::numbers::pi;
inline constexpr double kInf = std::numeric_limits<double>::infinity();
inline constexpr double kNaN = std::numeric_limits<double>::quiet_NaN();

}  // namespace piezoloop
