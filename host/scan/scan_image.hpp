// Images from a scan's pixels (scan_pixels.hpp), on a regular grid.
//
// Placement: each pixel sits where the scan commanded it (the image as the
// instrument makes it) or where the sensors say the stage was (the image at
// measured positions); both are resampled onto the same grid:
//   by lines (raster): each line's pixels, sorted along x, are linearly
//       interpolated onto the grid's columns within the line's extent (no
//       extrapolation), into the row nearest the line's mean y (the line
//       nearest a row wins it);
//   by cells (spiral, Lissajous, cycloid): each cell is the mean of the
//       pixels that fall into it.
// Cells no pixel reaches are NaN.
//
// The quantity is the probe's height (nm) or a tracking error, commanded -
// measured (µm), in x or in y.
#pragma once

#include <cstdint>
#include <vector>

#include "scan/scan_pixels.hpp"

namespace piezoloop::scan {

struct ImageGrid {
    int nx = 0, ny = 0;
    double x0_um = 0.0, y0_um = 0.0;  // the centre of cell (0, 0)
    double dx_um = 1.0, dy_um = 1.0;  // cell pitch (> 0)
    std::vector<double> value;        // row-major: value[j * nx + i] at (x0 + i dx, y0 + j dy)

    double x_um(int i) const { return x0_um + i * dx_um; }
    double y_um(int j) const { return y0_um + j * dy_um; }
    double at(int i, int j) const { return value[static_cast<std::size_t>(j) * nx + i]; }
};

enum class Placement { kCommanded, kMeasured };
enum class Quantity { kHeight, kErrorX, kErrorY };

// nx x ny cells covering [centre - size / 2, centre + size / 2] in each axis.
ImageGrid area_grid(double centre_x_um, double centre_y_um, double width_um, double height_um, int nx, int ny);
// A raster's grid: columns at frame `frame`'s commanded pixel positions
// (pixel 0 to the line's last, of its first line) and rows at its lines'
// commanded y (first to last line, evenly). Throws std::invalid_argument
// without two lines of two pixels.
ImageGrid raster_grid(const std::vector<ScanPixel>& pixels, uint32_t frame);

// Fills g.value from frame `frame`'s pixels.
void place_by_lines(ImageGrid& g, const std::vector<ScanPixel>& pixels, uint32_t frame, Placement where, Quantity what);
void place_by_cells(ImageGrid& g, const std::vector<ScanPixel>& pixels, uint32_t frame, Placement where, Quantity what);

}  // namespace piezoloop::scan
