#include "analysis/margins.hpp"

#include <algorithm>
#include <cmath>
#include <numbers>
#include <stdexcept>

#include "analysis/hinf.hpp"

namespace piezoloop::design {
namespace {

// Natural frequency (rad/s) and damping of a pole or zero.
bool natural(const cplx& p, double ts, double& wn, double& zeta) {
    cplx s = p;
    if (is_discrete(ts)) {
        if (std::abs(p) == 0.0) return false;  // pure delay: no frequency
        s = std::log(p) / ts;
    }
    wn = std::abs(s);
    if (!(wn > 0.0) || !std::isfinite(wn)) return false;
    zeta = -s.real() / wn;
    return true;
}

double wrap_pi(double a) {  // to (-π, π]
    a = std::remainder(a, 2.0 * std::numbers::pi);
    if (a <= -std::numbers::pi) a += 2.0 * std::numbers::pi;
    return a;
}

}  // namespace

FrequencySamples sample_response(const SsEvaluator& ev, const std::vector<double>& grid) {
    FrequencySamples s;
    for (double w : grid) {
        const cplx h = ev.at_w(w);
        if (!std::isfinite(h.real()) || !std::isfinite(h.imag()) || h == cplx(0.0)) continue;
        const double a = std::arg(h);
        const double ph = s.phase.empty() ? a : s.phase.back() + wrap_pi(a - std::arg(s.h.back()));
        s.w.push_back(w);
        s.h.push_back(h);
        s.phase.push_back(ph);
    }
    return s;
}

double phase_near(const SsEvaluator& ev, double w, double guess) {
    const double a = std::arg(ev.at_w(w));
    return a + 2.0 * std::numbers::pi * std::round((guess - a) / (2.0 * std::numbers::pi));
}

namespace {

// Bisection in log ω for a sign change of f on [a, b] (f(a), f(b) of
// opposite signs); 1e-12 relative.
template <class F>
double bisect_log(F f, double a, double b) {
    double fa = f(a);
    for (int i = 0; i < 200 && b / a - 1.0 > 1e-13; ++i) {
        const double m = std::sqrt(a * b);
        const double fm = f(m);
        if ((fm < 0.0) == (fa < 0.0)) {
            a = m;
            fa = fm;
        } else {
            b = m;
        }
    }
    return std::sqrt(a * b);
}

double phase_margin_deg(double phase_rad) { return wrap_pi(phase_rad + std::numbers::pi) * 180.0 / std::numbers::pi; }

}  // namespace

std::vector<double> analysis_grid(const std::vector<cplx>& critical, double ts, const std::vector<double>& extra_w) {
    if (!(ts >= 0.0) || !std::isfinite(ts)) throw std::invalid_argument("ts must be finite and >= 0");
    double lo = 0.0, hi = 0.0;
    std::vector<std::pair<double, double>> modes;
    for (const cplx& p : critical) {
        double wn = 0.0, zeta = 0.0;
        if (!natural(p, ts, wn, zeta)) continue;
        modes.emplace_back(wn, zeta);
        lo = lo == 0.0 ? wn : std::min(lo, wn);
        hi = std::max(hi, wn);
    }
    if (lo == 0.0) {
        lo = 1.0;
        hi = 1.0;
    }
    lo *= 1e-2;
    hi *= 1e2;
    if (is_discrete(ts)) {
        hi = std::numbers::pi / ts;
        lo = std::min(lo, 1e-3 * hi);
    }
    std::vector<double> w;
    const int per_decade = 200;
    const int n = std::max(2, static_cast<int>(std::ceil(std::log10(hi / lo) * per_decade)) + 1);
    for (int i = 0; i < n; ++i) w.push_back(lo * std::pow(hi / lo, static_cast<double>(i) / (n - 1)));
    w.back() = hi;
    for (const auto& [wn, zeta] : modes) {
        const double z = std::abs(zeta);
        if (z >= 0.5) continue;
        for (int k = -60; k <= 60; ++k) {
            const double x = wn * (1.0 + z * k / 10.0);
            if (x > lo && x < hi) w.push_back(x);
        }
    }
    for (double x : extra_w)
        if (x > 0.0 && std::isfinite(x) && (!is_discrete(ts) || x <= hi)) w.push_back(x);
    std::sort(w.begin(), w.end());
    std::vector<double> out;
    for (double x : w)
        if (out.empty() || x > out.back() * (1.0 + 1e-13)) out.push_back(x);
    return out;
}

Margins loop_margins(const Ss& loop, const std::vector<cplx>& critical) {
    const SsEvaluator ev(loop);
    const FrequencySamples s = sample_response(ev, analysis_grid(critical, loop.ts));
    Margins m;
    auto add_phase_crossover = [&](double w, cplx h) {
        PhaseCrossover c;
        c.w_rad_s = w;
        c.gain_margin = 1.0 / std::abs(h);
        c.gain_margin_db = 20.0 * std::log10(c.gain_margin);
        m.phase_crossovers.push_back(c);
    };
    // ω = 0 (and Nyquist for discrete models): L is real there.
    auto endpoint = [&](double w) {
        const cplx h = ev.at_w(w);
        if (std::isfinite(std::abs(h)) && h.real() < 0.0 && std::abs(h.imag()) <= 1e-9 * std::abs(h))
            add_phase_crossover(w, h);
    };
    endpoint(0.0);
    for (std::size_t i = 0; i + 1 < s.w.size(); ++i) {
        const double a = s.w[i], b = s.w[i + 1];
        // Gain crossovers.
        const double la = std::log(std::abs(s.h[i])), lb = std::log(std::abs(s.h[i + 1]));
        if ((la < 0.0) != (lb < 0.0)) {
            const double w = bisect_log([&](double x) { return std::log(std::abs(ev.at_w(x))); }, a, b);
            const double t = std::log(w / a) / std::log(b / a);
            const double ph = phase_near(ev, w, s.phase[i] + t * (s.phase[i + 1] - s.phase[i]));
            m.gain_crossovers.push_back({w, phase_margin_deg(ph)});
        }
        // Phase crossovers: odd multiples of π strictly crossed.
        const double pa = s.phase[i], pb = s.phase[i + 1];
        const double lo = std::min(pa, pb), hi = std::max(pa, pb);
        for (double k = std::ceil((lo / std::numbers::pi - 1.0) / 2.0); 2.0 * k + 1.0 <= hi / std::numbers::pi; k += 1.0) {
            const double target = (2.0 * k + 1.0) * std::numbers::pi;
            if (!(target > lo && target <= hi)) continue;
            auto f = [&](double x) {
                const double t = std::log(x / a) / std::log(b / a);
                return phase_near(ev, x, pa + t * (pb - pa)) - target;
            };
            const double w = bisect_log(f, a, b);
            add_phase_crossover(w, ev.at_w(w));
        }
    }
    if (is_discrete(loop.ts)) endpoint(std::numbers::pi / loop.ts);
    std::sort(m.phase_crossovers.begin(), m.phase_crossovers.end(),
              [](const auto& x, const auto& y) { return x.w_rad_s < y.w_rad_s; });
    for (const auto& c : m.phase_crossovers)
        if (!m.gain_margin || std::abs(c.gain_margin_db) < std::abs(m.gain_margin->gain_margin_db))
            m.gain_margin = c;
    for (const auto& c : m.gain_crossovers)
        if (!m.phase_margin || c.phase_margin_deg < m.phase_margin->phase_margin_deg) m.phase_margin = c;
    return m;
}

std::optional<double> bandwidth_rad_s(const Ss& closed_loop, const std::vector<cplx>& critical) {
    const SsEvaluator ev(closed_loop);
    const double t0 = std::abs(ev.at_w(0.0));
    if (!(t0 > 0.0) || !std::isfinite(t0)) return std::nullopt;
    const double level = std::log(t0 / std::sqrt(2.0));
    auto f = [&](double w) { return std::log(std::abs(ev.at_w(w))) - level; };
    double prev = 0.0;
    for (double w : analysis_grid(critical, closed_loop.ts)) {
        if (f(w) < 0.0) {
            if (prev == 0.0) {  // already below at the first grid point: bisect linearly from 0
                double a = 0.0, b = w;
                for (int i = 0; i < 200 && b - a > 1e-13 * b; ++i) {
                    const double m = 0.5 * (a + b);
                    (f(m) < 0.0 ? b : a) = m;
                }
                return 0.5 * (a + b);
            }
            return bisect_log(f, prev, w);
        }
        prev = w;
    }
    return std::nullopt;
}

double unwrapped_phase_deg(const Ss& model, const std::vector<cplx>& critical, double w_rad_s) {
    if (!(w_rad_s >= 0.0) || !std::isfinite(w_rad_s)) throw std::invalid_argument("frequency must be finite and >= 0");
    const SsEvaluator ev(model);
    std::vector<double> grid;
    for (double w : analysis_grid(critical, model.ts, {w_rad_s}))
        if (w <= w_rad_s) grid.push_back(w);
    if (grid.empty()) return std::arg(ev.at_w(w_rad_s)) * 180.0 / std::numbers::pi;
    const FrequencySamples s = sample_response(ev, grid);
    if (s.w.empty()) throw std::invalid_argument("model response is zero or infinite on the whole grid");
    return phase_near(ev, w_rad_s, s.phase.back()) * 180.0 / std::numbers::pi;
}

}  // namespace piezoloop::design
