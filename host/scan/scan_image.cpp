#include "scan/scan_image.hpp"

#include <algorithm>
#include <cmath>
#include <limits>
#include <map>
#include <stdexcept>

#include "numeric_constants.hpp"

namespace piezoloop::scan {
namespace {

double x_of(const ScanPixel& p, Placement w) { return w == Placement::kCommanded ? p.commanded_x_um : p.measured_x_um; }
double y_of(const ScanPixel& p, Placement w) { return w == Placement::kCommanded ? p.commanded_y_um : p.measured_y_um; }
double quantity_of(const ScanPixel& p, Quantity q) {
    switch (q) {
        case Quantity::kErrorX: return p.commanded_x_um - p.measured_x_um;
        case Quantity::kErrorY: return p.commanded_y_um - p.measured_y_um;
        default: return p.height_nm;
    }
}

// Frame `frame`'s pixels, by line.
std::map<uint32_t, std::vector<const ScanPixel*>> lines_of(const std::vector<ScanPixel>& pixels, uint32_t frame) {
    std::map<uint32_t, std::vector<const ScanPixel*>> lines;
    for (const ScanPixel& p : pixels)
        if (p.frame == frame) lines[p.line].push_back(&p);
    return lines;
}

}  // namespace

ImageGrid area_grid(double cx, double cy, double w, double h, int nx, int ny) {
    if (nx < 1 || ny < 1 || !(w > 0.0) || !(h > 0.0)) throw std::invalid_argument("image grid: empty");
    ImageGrid g;
    g.nx = nx;
    g.ny = ny;
    g.dx_um = w / nx;
    g.dy_um = h / ny;
    g.x0_um = cx - w / 2.0 + g.dx_um / 2.0;
    g.y0_um = cy - h / 2.0 + g.dy_um / 2.0;
    g.value.assign(static_cast<std::size_t>(nx) * ny, kNaN);
    return g;
}

ImageGrid raster_grid(const std::vector<ScanPixel>& pixels, uint32_t frame) {
    const auto lines = lines_of(pixels, frame);
    if (lines.size() < 2 || lines.begin()->second.size() < 2)
        throw std::invalid_argument("raster image: needs two lines of two pixels");
    const auto& first = lines.begin()->second;
    double ymin = first.front()->commanded_y_um, ymax = ymin;
    for (const auto& [n, line] : lines) {
        ymin = std::min(ymin, line.front()->commanded_y_um);
        ymax = std::max(ymax, line.front()->commanded_y_um);
    }
    double xa = first.front()->commanded_x_um, xb = first.back()->commanded_x_um;
    if (xb < xa) std::swap(xa, xb);
    ImageGrid g;
    g.nx = static_cast<int>(first.size());
    g.ny = static_cast<int>(lines.size());
    g.x0_um = xa;
    g.dx_um = (xb - xa) / (g.nx - 1);
    g.y0_um = ymin;
    g.dy_um = ymax > ymin ? (ymax - ymin) / (g.ny - 1) : 1.0;
    if (!(g.dx_um > 0.0)) throw std::invalid_argument("raster image: the line has no extent");
    g.value.assign(static_cast<std::size_t>(g.nx) * g.ny, kNaN);
    return g;
}

void place_by_lines(ImageGrid& g, const std::vector<ScanPixel>& pixels, uint32_t frame, Placement where, Quantity what) {
    std::fill(g.value.begin(), g.value.end(), kNaN);
    std::vector<double> row_distance(static_cast<std::size_t>(g.ny), std::numeric_limits<double>::infinity());
    for (const auto& [n, line] : lines_of(pixels, frame)) {
        std::vector<std::pair<double, double>> xv;
        double y = 0.0;
        for (const ScanPixel* p : line) {
            xv.emplace_back(x_of(*p, where), quantity_of(*p, what));
            y += y_of(*p, where);
        }
        y /= static_cast<double>(line.size());
        const int row = static_cast<int>(std::lround((y - g.y0_um) / g.dy_um));
        if (row < 0 || row >= g.ny) continue;
        const double dist = std::fabs(y - g.y_um(row));
        if (!(dist < row_distance[static_cast<std::size_t>(row)])) continue;
        row_distance[static_cast<std::size_t>(row)] = dist;
        std::stable_sort(xv.begin(), xv.end(), [](const auto& a, const auto& b) { return a.first < b.first; });
        std::size_t k = 0;
        for (int i = 0; i < g.nx; ++i) {
            double& cell = g.value[static_cast<std::size_t>(row) * g.nx + i];
            cell = kNaN;
            const double x = g.x_um(i);
            // Tolerate the grid's own rounding at the line's ends.
            const double eps = 1e-9 * g.dx_um;
            if (xv.size() == 1 || x < xv.front().first - eps || x > xv.back().first + eps) continue;
            while (k + 2 < xv.size() && xv[k + 1].first < x) ++k;
            const auto& [xa, va] = xv[k];
            const auto& [xb, vb] = xv[k + 1];
            const double t = xb > xa ? std::clamp((x - xa) / (xb - xa), 0.0, 1.0) : 0.0;
            cell = va + (vb - va) * t;
        }
    }
}

void place_by_cells(ImageGrid& g, const std::vector<ScanPixel>& pixels, uint32_t frame, Placement where, Quantity what) {
    std::vector<double> sum(g.value.size(), 0.0);
    std::vector<uint32_t> count(g.value.size(), 0);
    for (const ScanPixel& p : pixels) {
        if (p.frame != frame) continue;
        const int i = static_cast<int>(std::lround((x_of(p, where) - g.x0_um) / g.dx_um));
        const int j = static_cast<int>(std::lround((y_of(p, where) - g.y0_um) / g.dy_um));
        if (i < 0 || i >= g.nx || j < 0 || j >= g.ny) continue;
        const std::size_t c = static_cast<std::size_t>(j) * g.nx + i;
        sum[c] += quantity_of(p, what);
        ++count[c];
    }
    for (std::size_t c = 0; c < g.value.size(); ++c) g.value[c] = count[c] ? sum[c] / count[c] : kNaN;
}

}  // namespace piezoloop::scan
