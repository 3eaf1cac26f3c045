#include "ui/min_max_columns.hpp"

#include <cmath>
#include <limits>

namespace piezoloop::ui {

long column_of(double t_s, double t0_s, double span_s, std::size_t columns) {
    return static_cast<long>(std::floor((t_s - t0_s) / span_s * static_cast<double>(columns)));
}

ColumnPoints min_max_columns(std::span<const double> t_s, std::span<const float> v, double t0_s, double span_s,
                             std::size_t columns) {
    const float nan = std::numeric_limits<float>::quiet_NaN();
    ColumnPoints out;
    out.first.assign(columns, nan);
    out.second.assign(columns, nan);
    if (columns == 0 || !(span_s > 0.0)) return out;
    const std::size_t n = std::min(t_s.size(), v.size());
    std::size_t i = 0;
    while (i < n) {
        const long k = column_of(t_s[i], t0_s, span_s, columns);
        if (k < 0) {
            ++i;
            continue;
        }
        if (k >= static_cast<long>(columns)) break;
        // The run of samples in column k (times ascend).
        std::size_t lo = i, hi = i;
        std::size_t j = i + 1;
        for (; j < n && column_of(t_s[j], t0_s, span_s, columns) == k; ++j) {
            if (v[j] < v[lo]) lo = j;
            if (v[j] > v[hi]) hi = j;
        }
        const auto c = static_cast<std::size_t>(k);
        out.first[c] = lo <= hi ? v[lo] : v[hi];
        out.second[c] = lo <= hi ? v[hi] : v[lo];
        i = j;
    }
    return out;
}

}  // namespace piezoloop::ui
