#include "scan/scan_metrics.hpp"

#include <algorithm>
#include <cmath>
#include <limits>
#include <map>

#include "piezoloop/scan/scan_config.hpp"
#include "numeric_constants.hpp"

namespace piezoloop::scan {
namespace {

// The largest deviation from the least-squares line through (k, x_k).
double straight_line_deviation(const std::vector<double>& x) {
    const double n = static_cast<double>(x.size());
    double km = 0.0, xm = 0.0;
    for (std::size_t k = 0; k < x.size(); ++k) km += static_cast<double>(k), xm += x[k];
    km /= n;
    xm /= n;
    double skx = 0.0, skk = 0.0;
    for (std::size_t k = 0; k < x.size(); ++k) {
        skx += (static_cast<double>(k) - km) * (x[k] - xm);
        skk += (static_cast<double>(k) - km) * (static_cast<double>(k) - km);
    }
    const double slope = skx / skk;
    double worst = 0.0;
    for (std::size_t k = 0; k < x.size(); ++k)
        worst = std::max(worst, std::fabs(x[k] - (xm + slope * (static_cast<double>(k) - km))));
    return worst;
}

ScanTracking tracking_over(const std::vector<ScanTick>& ticks, const std::vector<char>& used, std::size_t from) {
    ScanTracking t;
    double sx = 0.0, sy = 0.0;
    for (std::size_t k = from; k < ticks.size(); ++k) {
        if (!used[k]) continue;
        const double ex = ticks[k].commanded_x_um - ticks[k].measured_x_um;
        const double ey = ticks[k].commanded_y_um - ticks[k].measured_y_um;
        sx += ex * ex;
        sy += ey * ey;
        t.max_x_um = std::max(t.max_x_um, std::fabs(ex));
        t.max_y_um = std::max(t.max_y_um, std::fabs(ey));
        ++t.used_ticks;
    }
    if (t.used_ticks > 0) {
        t.rms_x_um = std::sqrt(sx / static_cast<double>(t.used_ticks));
        t.rms_y_um = std::sqrt(sy / static_cast<double>(t.used_ticks));
    }
    return t;
}

}  // namespace

ScanMetrics compute_metrics(const std::vector<ScanTick>& ticks, const std::vector<ScanPixel>& pixels, double rate_Hz,
                            bool raster) {
    ScanMetrics m;
    m.ticks = ticks.size();
    m.pixels = pixels.size();
    std::vector<char> used(ticks.size(), 0);
    for (const ScanPixel& p : pixels)
        for (std::size_t k = p.first_tick; k < p.first_tick + p.ticks; ++k) used[k] = 1;

    m.tracking = tracking_over(ticks, used, 0);

    std::vector<std::size_t> line_starts, frame_starts;
    for (std::size_t k = 0; k < ticks.size(); ++k) {
        if (ticks[k].sync & kSyncLineStart) line_starts.push_back(k);
        if (ticks[k].sync & kSyncFrameStart) frame_starts.push_back(k);
    }
    m.lines = line_starts.size();
    if (line_starts.size() >= 2) {
        double sum = 0.0;
        for (std::size_t i = 0; i + 1 < line_starts.size(); ++i) {
            std::size_t in = 0;
            for (std::size_t k = line_starts[i]; k < line_starts[i + 1]; ++k) in += used[k] != 0;
            sum += static_cast<double>(in) / static_cast<double>(line_starts[i + 1] - line_starts[i]);
        }
        m.used_fraction = sum / static_cast<double>(line_starts.size() - 1);
    } else {
        m.used_fraction = kNaN;
    }

    m.linearity_um = kNaN;
    if (raster) {
        std::map<std::pair<uint32_t, uint32_t>, std::vector<double>> lines;  // (frame, line) -> x at the clocks
        for (const ScanPixel& p : pixels) lines[{p.frame, p.line}].push_back(ticks[p.first_tick].measured_x_um);
        m.linearity_um = 0.0;
        for (const auto& [key, x] : lines)
            if (x.size() >= 3) m.linearity_um = std::max(m.linearity_um, straight_line_deviation(x));
    }

    if (!frame_starts.empty()) {
        const std::size_t end = frame_starts.size() >= 2 ? frame_starts[1] : ticks.size();
        m.frame_time_s = static_cast<double>(end - frame_starts[0]) / rate_Hz;
        m.last_frame = tracking_over(ticks, used, frame_starts.back());
        m.last_frame_index = frame_starts.size() - 1;
    } else {
        m.last_frame = m.tracking;
    }
    return m;
}

}  // namespace piezoloop::scan
