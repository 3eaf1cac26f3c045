#include "scan/grating_pitch.hpp"

#include <algorithm>
#include <cmath>
#include <limits>
#include <vector>

#include "numeric_constants.hpp"

namespace piezoloop::scan {

GratingFit fit_grating(const ImageGrid& g) {
    GratingFit fit{kNaN, kNaN};
    double lo = std::numeric_limits<double>::infinity(), hi = -lo;
    for (const double v : g.value)
        if (std::isfinite(v)) lo = std::min(lo, v), hi = std::max(hi, v);
    if (!(hi > lo)) return fit;
    const double level = 0.5 * (lo + hi);

    std::vector<std::vector<double>> rows;
    std::vector<double> gaps;
    for (int j = 0; j < g.ny; ++j) {
        std::vector<double> xs;
        for (int i = 0; i + 1 < g.nx; ++i) {
            const double a = g.at(i, j), b = g.at(i + 1, j);
            if (!std::isfinite(a) || !std::isfinite(b)) continue;
            if (a < level && b >= level) xs.push_back(g.x_um(i) + g.dx_um * (level - a) / (b - a));
        }
        for (std::size_t k = 1; k < xs.size(); ++k) gaps.push_back(xs[k] - xs[k - 1]);
        if (xs.size() >= 2) rows.push_back(std::move(xs));
    }
    if (rows.empty()) return fit;
    std::nth_element(gaps.begin(), gaps.begin() + static_cast<std::ptrdiff_t>(gaps.size() / 2), gaps.end());
    const double p0 = gaps[gaps.size() / 2];

    double sxy = 0.0, sxx = 0.0;
    for (const auto& xs : rows) {
        std::vector<double> n(xs.size());
        double nm = 0.0, xm = 0.0;
        for (std::size_t k = 0; k < xs.size(); ++k) {
            n[k] = std::round((xs[k] - xs[0]) / p0);
            nm += n[k];
            xm += xs[k];
        }
        nm /= static_cast<double>(xs.size());
        xm /= static_cast<double>(xs.size());
        for (std::size_t k = 0; k < xs.size(); ++k) {
            sxy += (n[k] - nm) * (xs[k] - xm);
            sxx += (n[k] - nm) * (n[k] - nm);
        }
        fit.crossings += xs.size();
    }
    fit.rows = rows.size();
    if (!(sxx > 0.0)) return fit;
    fit.pitch_um = sxy / sxx;
    double phase = 0.0;
    for (const auto& xs : rows)
        for (const double x : xs) phase += std::remainder(x, fit.pitch_um);
    fit.phase_um = phase / static_cast<double>(fit.crossings);
    return fit;
}

}  // namespace piezoloop::scan
