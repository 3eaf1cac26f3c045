// A scan's figures from its ticks and pixels:
//   tracking error, commanded - measured, in x and y, RMS and max |.|, over
//       the used part of the lines (the ticks inside pixels), in µm and in
//       % of the scan's size along that axis;
//   used fraction: per line (from its line clock to the next line clock),
//       the share of ticks inside pixels; the mean over lines that have a
//       next line;
//   linearity (raster only, else NaN): per line, the measured fast-axis (x)
//       positions at the pixel clocks fitted by a straight line in the
//       pixel index (least squares); the largest deviation over all lines,
//       µm and % of the size in x;
//   frame time: ticks from the first frame clock to the next (or to the
//       last tick recorded) / rate, s of stage time.
#pragma once

#include <cstddef>
#include <vector>

#include "scan/scan_pixels.hpp"
#include "scan/scan_tick.hpp"

namespace piezoloop::scan {

struct ScanMetrics {
    std::size_t ticks = 0, used_ticks = 0, pixels = 0, lines = 0;
    double rms_error_x_um = 0.0, max_error_x_um = 0.0;
    double rms_error_y_um = 0.0, max_error_y_um = 0.0;
    double used_fraction = 0.0;  // NaN with fewer than two line clocks
    double linearity_um = 0.0;   // NaN when not a raster
    double frame_time_s = 0.0;
};

ScanMetrics compute_metrics(const std::vector<ScanTick>& ticks, const std::vector<ScanPixel>& pixels, double rate_Hz,
                            bool raster);

}  // namespace piezoloop::scan
