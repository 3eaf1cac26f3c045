#include "commission/uncertainty_weight.hpp"

#include <algorithm>
#include <cmath>
#include <numbers>
#include <stdexcept>

#include "numeric_constants.hpp"

namespace piezoloop::commission {

namespace {

double weight_at(double w, double r0, double wz, double wp) {
    return r0 * std::sqrt((1.0 + (w / wz) * (w / wz)) / (1.0 + (w / wp) * (w / wp)));
}

}  // namespace

UncertaintyWeight uncertainty_weight(const std::vector<double>& f_Hz, const std::vector<double>& delta) {
    if (f_Hz.empty() || f_Hz.size() != delta.size())
        throw std::invalid_argument("frf: the lines and their model errors differ in number, or there are none");
    for (std::size_t i = 0; i < f_Hz.size(); ++i)
        if (!(f_Hz[i] > 0.0) || !std::isfinite(f_Hz[i]) || !(delta[i] >= 0.0) || !std::isfinite(delta[i]) ||
            (i > 0 && !(f_Hz[i] > f_Hz[i - 1])))
            throw std::invalid_argument("frf: line " + std::to_string(i) +
                                        ": frequencies must be ascending and > 0, errors finite and >= 0");
    UncertaintyWeight u;
    // r0: the error at the lowest lines (up to five), at least 2 %.
    u.r0 = 0.02;
    for (std::size_t i = 0; i < std::min<std::size_t>(5, delta.size()); ++i) u.r0 = std::max(u.r0, delta[i]);
    u.r0 = std::min(u.r0, 0.5 * u.r_inf);
    const double ratio = u.r_inf / u.r0;
    auto covers = [&](double wz) {
        for (std::size_t i = 0; i < f_Hz.size(); ++i)
            if (delta[i] < u.r_inf && weight_at(kTwoPi * f_Hz[i], u.r0, wz, wz * ratio) < delta[i]) return false;
        return true;
    };
    // ω_z between a decade below the lowest line (the weight is then near
    // r∞ on every line: it covers whatever is coverable) and a decade above
    // the highest; the largest that covers.
    double lo = std::log(0.1 * kTwoPi * f_Hz.front()), hi = std::log(10.0 * kTwoPi * f_Hz.back());
    if (covers(std::exp(hi))) {
        lo = hi;
    } else {
        for (int it = 0; it < 60; ++it) {
            const double mid = 0.5 * (lo + hi);
            (covers(std::exp(mid)) ? lo : hi) = mid;
        }
    }
    u.wz_rad_s = std::exp(lo);
    u.wp_rad_s = u.wz_rad_s * ratio;
    for (std::size_t i = 0; i < f_Hz.size(); ++i)
        if (weight_at(kTwoPi * f_Hz[i], u.r0, u.wz_rad_s, u.wp_rad_s) < delta[i]) ++u.uncovered_lines;
    // r0 (1 + s/ωz) / (1 + s/ωp) = (r0 ωp / ωz) (s + ωz) / (s + ωp).
    u.w3 = design::Zpk{{design::cplx(-u.wz_rad_s)}, {design::cplx(-u.wp_rad_s)}, u.r0 * u.wp_rad_s / u.wz_rad_s, 0.0};
    return u;
}

}  // namespace piezoloop::commission
