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
//       last tick recorded) / rate, s of stage time;
//   the last frame's tracking error: as the whole run's, over the ticks from
//       the last frame clock on (a repetitive controller's scan after it has
//       learnt; the frame the images show).
#pragma once

#include <cstddef>
#include <vector>

#include "scan/scan_pixels.hpp"
#include "scan/scan_tick.hpp"

namespace piezoloop::scan {

// Tracking error commanded - measured over the used ticks of a span.
struct ScanTracking {
    std::size_t used_ticks = 0;
    double rms_x_um = 0.0, max_x_um = 0.0;
    double rms_y_um = 0.0, max_y_um = 0.0;
};

struct ScanMetrics {
    std::size_t ticks = 0, pixels = 0, lines = 0;
    ScanTracking tracking;         // the whole run (its used_ticks: the scan's)
    ScanTracking last_frame;       // from the last frame clock (the whole run without one)
    std::size_t last_frame_index = 0;  // frames counted from 0
    double used_fraction = 0.0;  // NaN with fewer than two line clocks
    double linearity_um = 0.0;   // NaN when not a raster
    double frame_time_s = 0.0;
};

ScanMetrics compute_metrics(const std::vector<ScanTick>& ticks, const std::vector<ScanPixel>& pixels, double rate_Hz,
                            bool raster);

}  // namespace piezoloop::scan
