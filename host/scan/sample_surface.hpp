// The emulated sample under the stage: a height map h(x, y) in nm over the
// stage's coordinates in µm, analytic so that a test can compare what a scan
// images against closed forms.
//
//   grating: lines along y, period pitch_um along x: h = height_nm where
//            frac(x / pitch) < duty (the raised part starts at x = 0), else 0
//   step:    h = height_nm for x >= x_um, else 0 (an edge along y)
//   dots:    round dots of radius_um and height_nm on a square lattice of
//            pitch_um, a dot centred on every (i pitch, j pitch)
#pragma once

#include <string>

namespace piezoloop::scan {

enum class SurfaceKind { kGrating, kStep, kDots };

struct SampleSurface {
    SurfaceKind kind = SurfaceKind::kGrating;
    double pitch_um = 2.0;    // grating, dots
    double height_nm = 50.0;  // all
    double duty = 0.5;        // grating: raised share of a period, (0, 1)
    double x_um = 0.0;        // step: the edge
    double radius_um = 0.5;   // dots: (0, pitch / 2)

    double height_at_nm(double x_um, double y_um) const;
    // "grating:pitch=2,height_nm=50,duty=0.5" and so on (sample_spec.hpp).
    std::string describe() const;
};

}  // namespace piezoloop::scan
