// The longest record a measurement (`measure frf`, `step`, `loops`) keeps.
#pragma once

#include <cstdint>

namespace piezoloop::measure {

// Bounds memory (a few doubles per tick, ~100 MB at this count) and wall
// time, and with them how long a board is kept busy; in ticks, since a
// 100 kHz loop fills it ten times faster than a 10 kHz one. Every plan is
// checked against it before anything is sent to a board.
inline constexpr uint64_t kMaxRecordTicks = 2'000'000;

}  // namespace piezoloop::measure
