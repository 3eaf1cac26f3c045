// The metrics of docs/models.md accumulated sample by sample over a steady-state window,
// so a run of 10^7 ticks per period (0.01 Hz at 100 kHz) needs no log.
// Same definitions as metrics.hpp (tracking_metrics, hysteresis_pct), which
// the tests use as the reference on stored data:
//   e = r - y; range = max r - min r; e_max = max |e|; e_rms = sqrt(mean e^2);
//   hysteresis: at the input midpoint V_M the first rising and the first
//   falling crossing of the input (linear interpolation between samples)
//   give X_up and X_lo; |X_up - X_lo| / (max y - min y) * 100. The window is
//   taken as cyclic (the step from its last sample back to its first counts),
//   as in metrics.cpp.
// The midpoint is given up front (the trajectory's offset: it is
// (max + min) / 2 of the reference by construction) because it must be known
// while streaming.
#pragma once

#include <cstdint>

#include "sim/metrics.hpp"

namespace piezoloop::sim {

class WindowMetrics {
public:
    explicit WindowMetrics(double midpoint = 0.0) : vm_(midpoint) {}

    void add(double r, double y);

    uint64_t samples() const { return n_; }
    TrackingMetrics tracking() const;
    // Negative if the input does not cross its midpoint both ways.
    double hysteresis_pct() const;

private:
    void crossing(double r0, double y0, double r1, double y1);

    double vm_;
    uint64_t n_ = 0;
    double r_first_ = 0.0, y_first_ = 0.0, r_last_ = 0.0, y_last_ = 0.0;
    double r_min_ = 0.0, r_max_ = 0.0, y_min_ = 0.0, y_max_ = 0.0;
    double e_min_ = 0.0, e_max_ = 0.0, e_abs_max_ = 0.0, e_sq_ = 0.0;
    bool have_up_ = false, have_lo_ = false;
    double x_up_ = 0.0, x_lo_ = 0.0;
};

}  // namespace piezoloop::sim
