#include "metrics.hpp"

#include <algorithm>
#include <cmath>
#include <stdexcept>

namespace piezoloop::sim {

TrackingMetrics tracking_metrics(std::span<const double> r, std::span<const double> y) {
    if (r.size() != y.size() || r.empty())
        throw std::invalid_argument("tracking_metrics: r and y must be non-empty and of equal length");
    TrackingMetrics m;
    const auto [rmin, rmax] = std::minmax_element(r.begin(), r.end());
    m.range_um = *rmax - *rmin;
    double emin = 0.0, emax = 0.0, sq = 0.0;
    for (size_t k = 0; k < r.size(); ++k) {
        const double e = r[k] - y[k];
        if (k == 0 || e < emin) emin = e;
        if (k == 0 || e > emax) emax = e;
        m.e_max_um = std::max(m.e_max_um, std::fabs(e));
        sq += e * e;
    }
    m.e_pp_um = emax - emin;
    m.e_rms_um = std::sqrt(sq / static_cast<double>(r.size()));
    if (m.range_um > 0.0) {
        m.e_max_pct = 100.0 * m.e_max_um / m.range_um;
        m.e_rms_pct = 100.0 * m.e_rms_um / m.range_um;
    }
    return m;
}

double hysteresis_pct(std::span<const double> input, std::span<const double> output) {
    if (input.size() != output.size() || input.size() < 3) return -1.0;
    const auto [vmin, vmax] = std::minmax_element(input.begin(), input.end());
    const auto [xmin, xmax] = std::minmax_element(output.begin(), output.end());
    const double vm = 0.5 * (*vmin + *vmax);
    bool have_up = false, have_lo = false;
    double x_up = 0.0, x_lo = 0.0;
    // The period is cyclic: also look at the crossing between the last and
    // the first sample.
    const size_t n = input.size();
    for (size_t k = 0; k < n; ++k) {
        const double v0 = input[k], v1 = input[(k + 1) % n];
        const double x0 = output[k], x1 = output[(k + 1) % n];
        if (v0 == v1) continue;
        const bool rising = v0 < vm && v1 >= vm;
        const bool falling = v0 > vm && v1 <= vm;
        if (!rising && !falling) continue;
        const double t = (vm - v0) / (v1 - v0);
        const double x = x0 + t * (x1 - x0);
        if (rising && !have_up) { x_up = x; have_up = true; }
        if (falling && !have_lo) { x_lo = x; have_lo = true; }
    }
    if (!have_up || !have_lo || !(*xmax > *xmin)) return -1.0;
    return 100.0 * std::fabs(x_up - x_lo) / (*xmax - *xmin);
}

}  // namespace piezoloop::sim
