#include "analysis/pi_composition.hpp"

#include <algorithm>
#include <cmath>
#include <stdexcept>
#include <string>

#include "status_text.hpp"

namespace piezoloop::design {
namespace {

void check_plain(const PiModel& m, const char* what) {
    if (const Status s = validate(m); !s.ok()) throw std::invalid_argument(std::string(what) + "." + describe(s));
    if (m.input_gain != 1.0f || m.input_offset != 0.0f)
        throw std::invalid_argument(std::string(what) +
                                    ": composition needs a plain PI model (input gain 1, offset 0)");
}

}  // namespace

double pi_loading_curve(const PiModel& m, double r) {
    double y = static_cast<double>(m.p0) * r;
    for (int j = 0; j < m.count; ++j) {
        const double rj = m.thresholds[static_cast<std::size_t>(j)];
        if (rj <= r) y += static_cast<double>(m.weights[static_cast<std::size_t>(j)]) * (r - rj);
    }
    return y;
}

PiComposition compose_pi(const PiModel& plant, const PiModel& inverse, double max_input) {
    check_plain(plant, "plant");
    check_plain(inverse, "inverse");
    if (!(max_input > 0.0)) throw std::invalid_argument("max_input must be > 0");

    // Breakpoints of ψ̂ (the inverse's thresholds) and of φ ∘ ψ̂ (where ψ̂
    // reaches one of φ's thresholds, searched segment by segment).
    std::vector<double> seg{0.0};
    for (int j = 0; j < inverse.count; ++j) {
        const double z = inverse.thresholds[static_cast<std::size_t>(j)];
        if (z > 0.0) seg.push_back(z);
    }
    std::vector<double> b(seg.begin() + 1, seg.end());
    for (std::size_t k = 0; k < seg.size(); ++k) {
        const double a = seg[k];
        const double e = k + 1 < seg.size() ? seg[k + 1] : std::numeric_limits<double>::infinity();
        const double fa = pi_loading_curve(inverse, a);
        // ψ̂ is linear on [a, e): its slope from a point inside.
        const double probe = std::isfinite(e) ? a + 0.5 * (e - a) : a + 1.0;
        const double s = (pi_loading_curve(inverse, probe) - fa) / (probe - a);
        if (s == 0.0) continue;
        for (int i = 0; i < plant.count; ++i) {
            const double r = plant.thresholds[static_cast<std::size_t>(i)];
            if (r <= 0.0) continue;
            const double v = a + (r - fa) / s;
            if (v > a && v < e) b.push_back(v);
        }
    }
    std::sort(b.begin(), b.end());
    // Breakpoints closer than 1e-6 of the largest one are merged: the models
    // hold float thresholds (6e-8 relative), so with an exact inverse ψ̂'s
    // thresholds and the preimages of φ's coincide only to that precision,
    // and a slope over such a sliver would be a pair of huge cancelling
    // weights.
    const double merge = b.empty() ? 0.0 : 1e-6 * b.back();
    std::vector<double> bp;
    for (double x : b)
        if (bp.empty() || x > bp.back() + merge) bp.push_back(x);

    auto eta = [&](double v) { return pi_loading_curve(plant, pi_loading_curve(inverse, v)); };
    PiComposition c;
    std::vector<double> pts{0.0};
    pts.insert(pts.end(), bp.begin(), bp.end());
    pts.push_back(pts.back() + std::max(1.0, pts.back()));
    for (double v : pts) {
        c.curve_v.push_back(v);
        c.curve_eta.push_back(eta(v));
    }
    std::vector<double> slopes;
    for (std::size_t k = 0; k + 1 < pts.size(); ++k)
        slopes.push_back((c.curve_eta[k + 1] - c.curve_eta[k]) / (pts[k + 1] - pts[k]));
    double smax = 0.0;
    for (double s : slopes) {
        smax = std::max(smax, std::abs(s));
        if (!(s > 0.0)) c.monotone = false;
    }
    c.p0 = slopes.front();
    c.rho = c.p0;
    for (std::size_t k = 1; k < slopes.size(); ++k) {
        const double p = slopes[k] - slopes[k - 1];
        const double r = pts[k];
        if (std::abs(p) <= 1e-12 * smax || r >= max_input) continue;
        c.thresholds.push_back(r);
        c.weights.push_back(p);
        c.rho += p;
        c.xi_bound += std::abs(p) * r;
    }
    return c;
}

}  // namespace piezoloop::design
