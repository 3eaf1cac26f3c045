// The recorder channels the host's record and measurement sessions read
// (a single-axis board's channel index is the signal's id).
#pragma once

#include <cstdint>

#include "piezoloop/recorder.hpp"

namespace piezoloop::hostlink {

inline constexpr uint8_t kSignalR = signal_index(SignalId::kR), kSignalY = signal_index(SignalId::kY),
                         kSignalU = signal_index(SignalId::kU), kSignalD = signal_index(SignalId::kD);

}  // namespace piezoloop::hostlink
