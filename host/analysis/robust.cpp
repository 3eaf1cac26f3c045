#include "analysis/robust.hpp"

#include <cmath>
#include <limits>
#include <stdexcept>

#include "analysis/analysis.hpp"
#include "lti/c2d.hpp"
#include "lti/freqresp.hpp"
#include "lti/lti_convert.hpp"
#include "analysis/margins.hpp"

namespace piezoloop::design {

FamilyResult coefficient_family(const Tf& plant, const Zpk& controller, const Zpk& hm, double rel, double ts) {
    if (!(rel > 0.0 && rel < 0.5)) throw std::invalid_argument("family: relative perturbation must be in (0, 0.5)");
    if (!(ts >= 0.0) || !std::isfinite(ts)) throw std::invalid_argument("family: ts must be finite and >= 0");
    if (plant.den.empty() || plant.den[0] == 0.0)
        throw std::invalid_argument("family: plant.den[0]: leading coefficient must be non-zero");
    const int n = static_cast<int>(plant.den.size()) - 1;
    if (n < 1 || n > 8) throw std::invalid_argument("family: the plant denominator must have 1 to 8 coefficients after the leading one");
    if (ts > 0.0 && (plant.ts != 0.0 || controller.ts != 0.0 || hm.ts != 0.0))
        throw std::invalid_argument("family: with a discretisation rate the models must be continuous");
    if (ts == 0.0 && (controller.ts != plant.ts || hm.ts != plant.ts))
        throw std::invalid_argument("family: plant, controller and H_m must share ts");
    auto prepare = [&](const Zpk& m) { return ts > 0.0 ? tustin(m, ts) : m; };
    const Zpk g = prepare(tf2zpk(plant));
    const Zpk k = prepare(controller);
    const Zpk w = prepare(hm);
    const double t = g.ts;
    const Ss kss = zpk2ss(k), wss = zpk2ss(w);

    std::vector<cplx> crit = critical_points(g, k);
    crit.insert(crit.end(), w.poles.begin(), w.poles.end());
    crit.insert(crit.end(), w.zeros.begin(), w.zeros.end());
    const std::vector<double> grid = analysis_grid(crit, t);
    std::vector<cplx> g_nom(grid.size()), w_nom(grid.size());
    for (std::size_t i = 0; i < grid.size(); ++i) {
        const cplx x = frequency_point(grid[i], t);
        g_nom[i] = evaluate(g, x);
        w_nom[i] = evaluate(w, x);
    }

    FamilyResult r;
    int total = 1;
    for (int i = 0; i < n; ++i) total *= 3;
    r.count = total;
    const double inf = std::numeric_limits<double>::infinity();
    r.worst_stability.stability_measure = -inf;
    r.worst_hinf_HmT.hinf_HmT = -inf;
    r.worst_coverage.coverage = -inf;
    for (int idx = 0; idx < total; ++idx) {
        FamilyMember m;
        Tf gi = plant;
        int code = idx;
        for (int j = 1; j <= n; ++j) {
            const double f = 1.0 + rel * static_cast<double>(code % 3 - 1);
            code /= 3;
            m.scale.push_back(f);
            gi.den[static_cast<std::size_t>(j)] *= f;
        }
        const Zpk gz = prepare(tf2zpk(gi));
        const FeedbackLoop f = feedback_loop(zpk2ss(gz), kss);
        m.stability_measure = stability_measure(f.S);
        m.stable = is_stable(f.S);
        if (!m.stable) ++r.unstable;
        m.hinf_HmT = m.stable ? hinf_norm(series(f.T, wss), 1e-6).norm : inf;
        // Coverage: grid maximum, then golden-section search between the
        // neighbours of the best grid point.
        auto cov = [&](double wv) {
            const cplx x = frequency_point(wv, t);
            return std::abs(evaluate(gz, x) / evaluate(g, x) - 1.0) / std::abs(evaluate(w, x));
        };
        std::size_t best = 0;
        for (std::size_t i = 0; i < grid.size(); ++i) {
            const cplx gv = evaluate(gz, frequency_point(grid[i], t));
            const double c = std::abs(gv / g_nom[i] - 1.0) / std::abs(w_nom[i]);
            if (c > m.coverage) {
                m.coverage = c;
                best = i;
            }
        }
        {
            double a = grid[best == 0 ? 0 : best - 1], b = grid[std::min(best + 1, grid.size() - 1)];
            const double phi = (std::sqrt(5.0) - 1.0) / 2.0;
            double x1 = b - phi * (b - a), x2 = a + phi * (b - a), f1 = cov(x1), f2 = cov(x2);
            for (int it = 0; it < 100 && b - a > 1e-13 * b; ++it) {
                if (f1 > f2) {
                    b = x2; x2 = x1; f2 = f1; x1 = b - phi * (b - a); f1 = cov(x1);
                } else {
                    a = x1; x1 = x2; f1 = f2; x2 = a + phi * (b - a); f2 = cov(x2);
                }
            }
            m.coverage = std::max({m.coverage, f1, f2});
        }
        if (const double c0 = cov(0.0); std::isfinite(c0)) m.coverage = std::max(m.coverage, c0);
        if (m.stability_measure > r.worst_stability.stability_measure) r.worst_stability = m;
        if (m.stable && m.hinf_HmT > r.worst_hinf_HmT.hinf_HmT) r.worst_hinf_HmT = m;
        if (m.coverage > r.worst_coverage.coverage) r.worst_coverage = m;
    }
    return r;
}

}  // namespace piezoloop::design
