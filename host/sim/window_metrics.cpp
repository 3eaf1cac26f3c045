#include "sim/window_metrics.hpp"

#include <algorithm>
#include <cmath>

namespace piezoloop::sim {

void WindowMetrics::crossing(double r0, double y0, double r1, double y1) {
    if (r0 == r1) return;
    const bool rising = r0 < vm_ && r1 >= vm_;
    const bool falling = r0 > vm_ && r1 <= vm_;
    if (!rising && !falling) return;
    const double t = (vm_ - r0) / (r1 - r0);
    const double x = y0 + t * (y1 - y0);
    if (rising && !have_up_) {
        x_up_ = x;
        have_up_ = true;
    }
    if (falling && !have_lo_) {
        x_lo_ = x;
        have_lo_ = true;
    }
}

void WindowMetrics::add(double r, double y) {
    const double e = r - y;
    if (n_ == 0) {
        r_first_ = r;
        y_first_ = y;
        r_min_ = r_max_ = r;
        y_min_ = y_max_ = y;
        e_min_ = e_max_ = e;
    } else {
        crossing(r_last_, y_last_, r, y);
        r_min_ = std::min(r_min_, r);
        r_max_ = std::max(r_max_, r);
        y_min_ = std::min(y_min_, y);
        y_max_ = std::max(y_max_, y);
        e_min_ = std::min(e_min_, e);
        e_max_ = std::max(e_max_, e);
    }
    e_abs_max_ = std::max(e_abs_max_, std::fabs(e));
    e_sq_ += e * e;
    r_last_ = r;
    y_last_ = y;
    ++n_;
}

TrackingMetrics WindowMetrics::tracking() const {
    TrackingMetrics m;
    if (n_ == 0) return m;
    m.range_um = r_max_ - r_min_;
    m.e_max_um = e_abs_max_;
    m.e_pp_um = e_max_ - e_min_;
    m.e_rms_um = std::sqrt(e_sq_ / static_cast<double>(n_));
    if (m.range_um > 0.0) {
        m.e_max_pct = 100.0 * m.e_max_um / m.range_um;
        m.e_rms_pct = 100.0 * m.e_rms_um / m.range_um;
    }
    return m;
}

double WindowMetrics::hysteresis_pct() const {
    if (n_ < 3) return -1.0;
    // The cyclic closing step, without changing the accumulated state.
    WindowMetrics tail = *this;
    tail.crossing(r_last_, y_last_, r_first_, y_first_);
    if (!tail.have_up_ || !tail.have_lo_ || !(y_max_ > y_min_)) return -1.0;
    return 100.0 * std::fabs(tail.x_up_ - tail.x_lo_) / (y_max_ - y_min_);
}

}  // namespace piezoloop::sim
