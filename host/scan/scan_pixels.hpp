// Pixels from a scan's ticks: a pixel starts at a pixel clock (kSyncPixel)
// and takes the ticks up to the next pixel clock, but no more than the
// usual pixel length L (the most frequent distance between consecutive
// pixel clocks), so the last pixel of a line ends where its neighbours do
// and not at the next line. Every recorded quantity is the mean over the
// pixel's ticks. Lines and frames are counted from their clocks (the first
// line of a frame is 0; a pixel before any line clock is in line 0).
#pragma once

#include <cstdint>
#include <vector>

#include "scan/scan_tick.hpp"

namespace piezoloop::scan {

struct ScanPixel {
    uint32_t frame = 0, line = 0, index = 0;  // index along its line
    std::size_t first_tick = 0;
    uint32_t ticks = 0;
    double commanded_x_um = 0.0, commanded_y_um = 0.0;
    double measured_x_um = 0.0, measured_y_um = 0.0;
    double true_x_um = 0.0, true_y_um = 0.0;
    double height_nm = 0.0;
};

// The usual pixel length L in ticks (0 with fewer than two pixel clocks).
uint32_t usual_pixel_ticks(const std::vector<ScanTick>& ticks);

std::vector<ScanPixel> form_pixels(const std::vector<ScanTick>& ticks);

}  // namespace piezoloop::scan
