// A scan's ticks as CSV, one row a tick from the scan's first tick (after
// the approach): tick, commanded_x_um, commanded_y_um, measured_x_um,
// measured_y_um, true_x_um, true_y_um, height_nm, sync (the kSync* bits:
// 1 frame start, 2 line start, 4 pixel clock). Positions and heights with 9
// significant digits (every float exactly). Throws std::runtime_error if
// the file cannot be written.
#pragma once

#include <filesystem>
#include <vector>

#include "scan/scan_tick.hpp"

namespace piezoloop::scan {

void write_scan_csv(const std::filesystem::path& file, const std::vector<ScanTick>& ticks);

}  // namespace piezoloop::scan
