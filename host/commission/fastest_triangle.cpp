#include "commission/fastest_triangle.hpp"

#include <algorithm>
#include <cmath>
#include <stdexcept>

#include "format/number.hpp"

namespace piezoloop::commission {

FastestTriangle fastest_triangle(std::vector<TrackingPoint> points, double tolerance_pct) {
    if (!(tolerance_pct > 0.0) || !std::isfinite(tolerance_pct))
        throw std::invalid_argument("tolerance_pct: must be finite and > 0");
    if (points.empty()) throw std::invalid_argument("points: at least one tracking run is needed");
    for (const TrackingPoint& p : points) {
        if (!(p.frequency_Hz > 0.0) || !std::isfinite(p.frequency_Hz))
            throw std::invalid_argument("frequency_Hz: must be finite and > 0");
        if (!(p.e_max_pct >= 0.0) || !std::isfinite(p.e_max_pct))
            throw std::invalid_argument("e_max_pct: must be finite and >= 0");
    }
    std::sort(points.begin(), points.end(),
              [](const TrackingPoint& a, const TrackingPoint& b) { return a.frequency_Hz < b.frequency_Hz; });
    for (std::size_t i = 1; i < points.size(); ++i)
        if (points[i].frequency_Hz == points[i - 1].frequency_Hz)
            throw std::invalid_argument("frequency_Hz: two runs at " + format::significant(points[i].frequency_Hz) + " Hz");

    FastestTriangle fastest;
    fastest.runs = points;
    fastest.tolerance_pct = tolerance_pct;
    if (points.front().e_max_pct > tolerance_pct) return fastest;
    std::size_t i = 0;
    while (i + 1 < points.size() && points[i + 1].e_max_pct <= tolerance_pct) ++i;
    if (i + 1 == points.size()) {
        fastest.up_to_Hz = points.back().frequency_Hz;
        fastest.at_least = true;
        return fastest;
    }
    const TrackingPoint& a = points[i];
    const TrackingPoint& b = points[i + 1];
    // e = e_a (f / f_a)^k through both runs; a run of zero error has no
    // logarithm: the line then starts at the tolerance's thousandth.
    const double ea = std::max(a.e_max_pct, 1e-3 * tolerance_pct);
    const double k = std::log(b.e_max_pct / ea) / std::log(b.frequency_Hz / a.frequency_Hz);
    fastest.up_to_Hz = a.frequency_Hz * std::pow(tolerance_pct / ea, 1.0 / k);
    return fastest;
}

std::string describe(const FastestTriangle& fastest) {
    std::string runs;
    for (const TrackingPoint& p : fastest.runs)
        runs += (runs.empty() ? "" : ", ") + format::significant(p.e_max_pct, 2) + " % at " + format::significant(p.frequency_Hz, 3) + " Hz";
    const std::string tol = format::significant(fastest.tolerance_pct) + " %";
    if (fastest.up_to_Hz == 0.0)
        return "triangles over the whole range: not within " + tol + " even at " +
               format::significant(fastest.runs.front().frequency_Hz, 3) + " Hz (" + runs + ")";
    return "triangles over the whole range within " + tol + (fastest.at_least ? " up to at least " : " up to about ") +
           format::significant(fastest.up_to_Hz, 3) + " Hz (" + runs + ")";
}

}  // namespace piezoloop::commission
