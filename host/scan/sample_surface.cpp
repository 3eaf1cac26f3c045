#include "scan/sample_surface.hpp"

#include <cmath>
#include <sstream>

namespace piezoloop::scan {

double SampleSurface::height_at_nm(double x, double y) const {
    switch (kind) {
        case SurfaceKind::kGrating: {
            const double phase = x / pitch_um - std::floor(x / pitch_um);
            return phase < duty ? height_nm : 0.0;
        }
        case SurfaceKind::kStep: return x >= x_um ? height_nm : 0.0;
        case SurfaceKind::kDots: {
            const double dx = x - pitch_um * std::round(x / pitch_um);
            const double dy = y - pitch_um * std::round(y / pitch_um);
            return dx * dx + dy * dy <= radius_um * radius_um ? height_nm : 0.0;
        }
    }
    return 0.0;
}

std::string SampleSurface::describe() const {
    std::ostringstream o;
    switch (kind) {
        case SurfaceKind::kGrating: o << "grating:pitch=" << pitch_um << ",height_nm=" << height_nm << ",duty=" << duty; break;
        case SurfaceKind::kStep: o << "step:x=" << x_um << ",height_nm=" << height_nm; break;
        case SurfaceKind::kDots: o << "dots:pitch=" << pitch_um << ",radius=" << radius_um << ",height_nm=" << height_nm; break;
    }
    return o.str();
}

}  // namespace piezoloop::scan
