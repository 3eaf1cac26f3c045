// A grating's pitch measured from an image: along every row, the rising
// crossings of the level halfway between the image's lowest and highest
// values (linear interpolation between neighbouring cells, cells both
// finite), then one straight line x = x_row + pitch * n through all rows'
// crossings at once (least squares with an intercept per row; n counts the
// periods from a row's first crossing, rounded with the median distance
// between consecutive crossings). Rows with fewer than two crossings add
// nothing. The phase is the mean of the crossings modulo the pitch, in
// (-pitch / 2, pitch / 2]: where the rising edges appear.
#pragma once

#include <cstddef>

#include "scan/scan_image.hpp"

namespace piezoloop::scan {

struct GratingFit {
    double pitch_um;   // NaN when no row has two crossings
    double phase_um;
    std::size_t crossings = 0;  // used in the fit
    std::size_t rows = 0;
};

GratingFit fit_grating(const ImageGrid& image);

}  // namespace piezoloop::scan
