// One tick of a scan as recorded: where the scan commanded the stage, where
// its sensors say it was, where it truly was, what the probe read there, and
// the tick's sync word (scan_config.hpp: frame, line, pixel clocks).
#pragma once

#include <cstdint>

namespace piezoloop::scan {

struct ScanTick {
    double commanded_x_um = 0.0, commanded_y_um = 0.0;
    double measured_x_um = 0.0, measured_y_um = 0.0;
    double true_x_um = 0.0, true_y_um = 0.0;
    double height_nm = 0.0;
    uint32_t sync = 0;
};

}  // namespace piezoloop::scan
