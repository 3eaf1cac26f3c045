#include "analysis/mu.hpp"

#include <algorithm>
#include <cmath>
#include <functional>
#include <sstream>
#include <limits>
#include <stdexcept>
#include <string>

#include <Eigen/Eigenvalues>
#include <Eigen/SVD>

#include "analysis/analysis.hpp"
#include "analysis/hinf.hpp"
#include "analysis/margins.hpp"
#include "lti/freqresp.hpp"
#include "lti/lti_convert.hpp"

namespace piezoloop::design {
namespace {

// log d is kept within ±kLogCap: when a block row or column of M vanishes
// the infimum is only approached as d → 0 or ∞, and e^46 ≈ 1e20 already
// makes the remaining coupling negligible against double precision.
constexpr double kLogCap = 46.0;
// Golden-section width in log d: the bound is then within about 1e-10
// relative of the minimum even where φ has a kink (slope <= 1 in log σ̄
// per unit of log d for normalised singular vectors).
constexpr double kLogTol = 1e-10;
const double kGolden = (std::sqrt(5.0) - 1.0) / 2.0;

struct Layout {
    std::vector<Eigen::Index> z_off, w_off;  // start of each block (size F + 1)
};

Layout layout_of(const Eigen::MatrixXcd& m, const std::vector<MuBlock>& blocks) {
    if (blocks.empty()) throw std::invalid_argument("mu: at least one block");
    Layout l;
    l.z_off.push_back(0);
    l.w_off.push_back(0);
    for (std::size_t i = 0; i < blocks.size(); ++i) {
        if (blocks[i].z_size < 1 || blocks[i].w_size < 1)
            throw std::invalid_argument("mu: block " + std::to_string(i) + " must be at least 1 x 1");
        l.z_off.push_back(l.z_off.back() + blocks[i].z_size);
        l.w_off.push_back(l.w_off.back() + blocks[i].w_size);
    }
    if (l.z_off.back() != m.rows() || l.w_off.back() != m.cols())
        throw std::invalid_argument("mu: blocks cover " + std::to_string(l.z_off.back()) + " x " +
                                    std::to_string(l.w_off.back()) + ", M is " + std::to_string(m.rows()) + " x " +
                                    std::to_string(m.cols()));
    if (!m.allFinite()) throw std::invalid_argument("mu: M has a non-finite entry");
    return l;
}

Eigen::MatrixXcd scaled(const Eigen::MatrixXcd& m, const Layout& l, const std::vector<double>& d) {
    Eigen::MatrixXcd a = m;
    const std::size_t f = d.size();
    for (std::size_t i = 0; i < f; ++i) {
        a.middleRows(l.z_off[i], l.z_off[i + 1] - l.z_off[i]) *= d[i];
        a.middleCols(l.w_off[i], l.w_off[i + 1] - l.w_off[i]) /= d[i];
    }
    return a;
}

// The objective on x = log d (free entries only, d_F = 1).
class Objective {
public:
    Objective(const Eigen::MatrixXcd& m, const Layout& l, std::size_t blocks) : m_(m), l_(l), f_(blocks) {}

    std::vector<double> d_of(const Eigen::VectorXd& x) const {
        std::vector<double> d(f_, 1.0);
        for (Eigen::Index i = 0; i < x.size(); ++i) d[static_cast<std::size_t>(i)] = std::exp(x(i));
        return d;
    }
    // σ̄ of the scaled matrix; with `grad`, ∂ log σ̄ / ∂x_i = ‖u_i‖² − ‖v_i‖²
    // (valid where σ̄ is simple; a subgradient otherwise).
    double sigma(const Eigen::VectorXd& x, Eigen::VectorXd* grad = nullptr) {
        ++evaluations;
        const Eigen::MatrixXcd a = scaled(m_, l_, d_of(x));
        if (!grad) {
            Eigen::JacobiSVD<Eigen::MatrixXcd> svd(a);
            return svd.singularValues()(0);
        }
        Eigen::JacobiSVD<Eigen::MatrixXcd> svd(a, Eigen::ComputeThinU | Eigen::ComputeThinV);
        grad->resize(x.size());
        for (Eigen::Index i = 0; i < x.size(); ++i) {
            const auto k = static_cast<std::size_t>(i);
            (*grad)(i) = svd.matrixU().col(0).segment(l_.z_off[k], l_.z_off[k + 1] - l_.z_off[k]).squaredNorm() -
                         svd.matrixV().col(0).segment(l_.w_off[k], l_.w_off[k + 1] - l_.w_off[k]).squaredNorm();
        }
        return svd.singularValues()(0);
    }
    int evaluations = 0;

private:
    const Eigen::MatrixXcd& m_;
    const Layout& l_;
    std::size_t f_;
};

// Osborne's iteration on the block-norm matrix B: each d_i² in turn
// minimises d_i² Σ_j B_ij²/d_j² + d_i⁻² Σ_j B_ji² d_j² (the terms of
// ‖D B D⁻¹‖_F² that involve it), i.e. d_i² = sqrt(col_i / row_i).
std::vector<double> osborne(const Eigen::MatrixXcd& m, const Layout& l, std::size_t f) {
    Eigen::MatrixXd b2(static_cast<Eigen::Index>(f), static_cast<Eigen::Index>(f));
    for (std::size_t i = 0; i < f; ++i)
        for (std::size_t j = 0; j < f; ++j)
            b2(static_cast<Eigen::Index>(i), static_cast<Eigen::Index>(j)) =
                m.block(l.z_off[i], l.w_off[j], l.z_off[i + 1] - l.z_off[i], l.w_off[j + 1] - l.w_off[j])
                    .squaredNorm();
    std::vector<double> d2(f, 1.0);
    for (int sweep = 0; sweep < 100; ++sweep) {
        double change = 0.0;
        for (std::size_t i = 0; i < f; ++i) {
            double row = 0.0, col = 0.0;
            for (std::size_t j = 0; j < f; ++j) {
                if (j == i) continue;
                row += b2(static_cast<Eigen::Index>(i), static_cast<Eigen::Index>(j)) / d2[j];
                col += b2(static_cast<Eigen::Index>(j), static_cast<Eigen::Index>(i)) * d2[j];
            }
            if (row <= 0.0 || col <= 0.0) continue;  // decoupled from one side: leave it
            const double next = std::sqrt(col / row);
            change = std::max(change, std::abs(std::log(next / d2[i])));
            d2[i] = next;
        }
        if (change < 1e-6) break;
    }
    std::vector<double> d(f);
    for (std::size_t i = 0; i < f; ++i) d[i] = std::sqrt(d2[i] / d2[f - 1]);
    return d;
}

// Minimises the convex σ̄ along coordinate k of x: bracket from x(k) by
// doubling steps, then golden-section search to kLogTol. Returns σ̄ at the
// new x (which it updates), never more than at the old one.
double line_min(Objective& obj, Eigen::VectorXd& x, Eigen::Index k, double f0) {
    auto at = [&](double t) {
        Eigen::VectorXd y = x;
        y(k) = t;
        return obj.sigma(y);
    };
    double c = x(k), fc = f0, h = 0.5;
    double lo = std::max(c - h, -kLogCap), flo = at(lo);
    double hi = std::min(c + h, kLogCap), fhi = at(hi);
    // Walk downhill; convexity makes the first rise a bracket.
    while (flo < fc && lo > -kLogCap) {
        hi = c; fhi = fc; c = lo; fc = flo; h *= 2.0;
        lo = std::max(c - h, -kLogCap); flo = at(lo);
    }
    while (fhi < fc && hi < kLogCap) {
        lo = c; flo = fc; c = hi; fc = fhi; h *= 2.0;
        hi = std::min(c + h, kLogCap); fhi = at(hi);
    }
    double best = fc, best_x = c;
    if (flo < best) { best = flo; best_x = lo; }
    if (fhi < best) { best = fhi; best_x = hi; }
    double a = lo, b = hi;
    double x1 = b - kGolden * (b - a), x2 = a + kGolden * (b - a);
    double f1 = at(x1), f2 = at(x2);
    while (b - a > kLogTol) {
        if (f1 <= f2) {
            b = x2; x2 = x1; f2 = f1; x1 = b - kGolden * (b - a); f1 = at(x1);
        } else {
            a = x1; x1 = x2; f1 = f2; x2 = a + kGolden * (b - a); f2 = at(x2);
        }
    }
    if (f1 < best) { best = f1; best_x = x1; }
    if (f2 < best) { best = f2; best_x = x2; }
    if (best < f0) {
        x(k) = best_x;
        return best;
    }
    return f0;
}

// BFGS on log σ̄ with the weak Wolfe line search of Lewis & Overton (2013):
// bisection/doubling on t until sufficient decrease (c1) and the curvature
// condition (c2) hold.
double bfgs(Objective& obj, Eigen::VectorXd& x) {
    const Eigen::Index n = x.size();
    Eigen::VectorXd g;
    double f = std::log(obj.sigma(x, &g));
    Eigen::MatrixXd h = Eigen::MatrixXd::Identity(n, n);
    constexpr double c1 = 1e-4, c2 = 0.9;
    for (int it = 0; it < 200; ++it) {
        if (g.norm() < 1e-13) break;
        Eigen::VectorXd p = -h * g;
        double slope = g.dot(p);
        if (!(slope < 0.0)) {
            h.setIdentity();
            p = -g;
            slope = -g.squaredNorm();
        }
        double lo = 0.0, hi = std::numeric_limits<double>::infinity(), t = 1.0;
        bool ok = false;
        Eigen::VectorXd g_t, x_t;
        double f_t = f;
        for (int ls = 0; ls < 60; ++ls) {
            x_t = (x + t * p).cwiseMax(-kLogCap).cwiseMin(kLogCap);
            f_t = std::log(obj.sigma(x_t, &g_t));
            if (f_t > f + c1 * t * slope) hi = t;
            else if (g_t.dot(p) < c2 * slope) lo = t;
            else { ok = true; break; }
            t = std::isfinite(hi) ? 0.5 * (lo + hi) : 2.0 * t;
        }
        if (!ok) {
            if (lo > 0.0) {  // a decrease without the curvature condition: take it and stop
                x_t = (x + lo * p).cwiseMax(-kLogCap).cwiseMin(kLogCap);
                f_t = std::log(obj.sigma(x_t, &g_t));
                if (f_t < f) { x = x_t; f = f_t; }
            }
            break;
        }
        const Eigen::VectorXd s = x_t - x, y = g_t - g;
        const double decrease = f - f_t;
        x = x_t; f = f_t; g = g_t;
        const double sy = s.dot(y);
        if (sy > 1e-300) {
            const double rho = 1.0 / sy;
            const Eigen::MatrixXd v = Eigen::MatrixXd::Identity(n, n) - rho * y * s.transpose();
            h = v.transpose() * h * v + rho * s * s.transpose();
        }
        if (decrease < 1e-15 && s.norm() < 1e-10) break;
    }
    return std::exp(f);
}

// ρ(A Δ) for Δ = diag(a_i x_iᴴ / (‖a_i‖ ‖x_i‖)) (zero blocks where a vector
// part vanishes: still a contraction).
Eigen::MatrixXcd aligned_delta(const Layout& l, std::size_t f, const Eigen::VectorXcd& w_part,
                               const Eigen::VectorXcd& z_part) {
    Eigen::MatrixXcd delta = Eigen::MatrixXcd::Zero(l.w_off.back(), l.z_off.back());
    for (std::size_t i = 0; i < f; ++i) {
        const Eigen::Index wn = l.w_off[i + 1] - l.w_off[i], zn = l.z_off[i + 1] - l.z_off[i];
        const Eigen::VectorXcd a = w_part.segment(l.w_off[i], wn), x = z_part.segment(l.z_off[i], zn);
        const double na = a.norm(), nx = x.norm();
        if (na > 0.0 && nx > 0.0) delta.block(l.w_off[i], l.z_off[i], wn, zn) = a * x.adjoint() / (na * nx);
    }
    return delta;
}

double lower_bound(const Eigen::MatrixXcd& a, const Layout& l, std::size_t f) {
    Eigen::JacobiSVD<Eigen::MatrixXcd> svd(a, Eigen::ComputeThinU | Eigen::ComputeThinV);
    // σ̄ u = A v: Δ_i ∝ v_i u_iᴴ maps the z-part u to the w-part v.
    Eigen::MatrixXcd delta = aligned_delta(l, f, svd.matrixV().col(0), svd.matrixU().col(0));
    double best = 0.0;
    for (int it = 0; it < 30; ++it) {
        const Eigen::MatrixXcd ad = a * delta;
        Eigen::ComplexEigenSolver<Eigen::MatrixXcd> right(ad), left(ad.adjoint());
        if (right.info() != Eigen::Success || left.info() != Eigen::Success) break;
        Eigen::Index k = 0;
        right.eigenvalues().cwiseAbs().maxCoeff(&k);
        const cplx lambda = right.eigenvalues()(k);
        const double rho = std::abs(lambda);
        if (it > 0 && rho <= best * (1.0 + 1e-12)) {
            best = std::max(best, rho);
            break;
        }
        best = std::max(best, rho);
        if (rho == 0.0) break;
        Eigen::Index kl = 0;
        (left.eigenvalues().array() - std::conj(lambda)).abs().minCoeff(&kl);
        const Eigen::VectorXcd x = right.eigenvectors().col(k), y = left.eigenvectors().col(kl);
        delta = aligned_delta(l, f, a.adjoint() * y, x);
    }
    return best;
}

}  // namespace

double scaled_sigma_max(const Eigen::MatrixXcd& m, const std::vector<MuBlock>& blocks, const std::vector<double>& d) {
    const Layout l = layout_of(m, blocks);
    if (d.size() != blocks.size()) throw std::invalid_argument("mu: one scaling per block");
    Eigen::JacobiSVD<Eigen::MatrixXcd> svd(scaled(m, l, d));
    return svd.singularValues()(0);
}

MuBound mu_bounds(const Eigen::MatrixXcd& m, const std::vector<MuBlock>& blocks, const std::vector<double>& d_start) {
    const Layout l = layout_of(m, blocks);
    const std::size_t f = blocks.size();
    MuBound r;
    if (m.size() == 0 || m.cwiseAbs().maxCoeff() == 0.0) {
        r.d.assign(f, 1.0);
        return r;
    }
    Objective obj(m, l, f);
    const auto n = static_cast<Eigen::Index>(f - 1);
    Eigen::VectorXd x = Eigen::VectorXd::Zero(n);
    double s = 0.0;
    if (n > 0) {
        // Osborne's start, or the caller's if it is better.
        const std::vector<double> d0 = osborne(m, l, f);
        for (Eigen::Index i = 0; i < n; ++i) x(i) = std::clamp(std::log(d0[static_cast<std::size_t>(i)]), -kLogCap, kLogCap);
        s = obj.sigma(x);
        if (d_start.size() == f) {
            Eigen::VectorXd xs(n);
            bool valid = true;
            for (Eigen::Index i = 0; i < n; ++i) {
                const double di = d_start[static_cast<std::size_t>(i)] / d_start.back();
                valid = valid && std::isfinite(di) && di > 0.0;
                xs(i) = valid ? std::clamp(std::log(di), -kLogCap, kLogCap) : 0.0;
            }
            if (valid) {
                const double ss = obj.sigma(xs);
                if (ss < s) { s = ss; x = xs; }
            }
        }
        if (n == 1) {
            s = line_min(obj, x, 0, s);
        } else {
            s = bfgs(obj, x);
            // Coordinate passes: a nonsmooth point BFGS stalled at is left
            // along an axis when the convex φ still descends there.
            for (int pass = 0; pass < 4; ++pass) {
                const double before = s;
                for (Eigen::Index k = 0; k < n; ++k) s = line_min(obj, x, k, s);
                if (before - s <= 1e-13 * before) break;
            }
        }
    } else {
        s = obj.sigma(x);
    }
    r.upper = s;
    r.d = obj.d_of(x);
    r.evaluations = obj.evaluations;
    r.lower = std::min(lower_bound(scaled(m, l, r.d), l, f), r.upper);
    return r;
}

// ---------------------------------------------------------------- loop

Eigen::MatrixXcd mu_loop_matrix(const MuLoopModels& mdl, double w_rad_s) {
    const double ts = mdl.plant.ts;
    const cplx x = frequency_point(w_rad_s, ts);
    const cplx g = evaluate(mdl.plant, x), k = evaluate(mdl.controller, x);
    const cplx hm = evaluate(mdl.hm, x), w1 = evaluate(mdl.w1, x);
    const cplx s = 1.0 / (1.0 + g * k), t = g * k * s;
    const Eigen::Index rows = 2 + (mdl.has_w3 ? 1 : 0) + (mdl.has_w2 ? 1 : 0);
    Eigen::MatrixXcd n(rows, 2);
    n(0, 0) = -hm * t;
    n(0, 1) = hm * k * s;
    n(1, 0) = -w1 * g * s;
    n(1, 1) = w1 * s;
    Eigen::Index row = 2;
    if (mdl.has_w3) {
        const cplx w3 = evaluate(mdl.w3, x);
        n(row, 0) = w3 * g * s;
        n(row, 1) = w3 * t;
        ++row;
    }
    if (mdl.has_w2) {
        const cplx w2 = evaluate(mdl.w2, x);
        n(row, 0) = -w2 * t;
        n(row, 1) = w2 * k * s;
    }
    return n;
}

MuPoint mu_loop_point(const MuLoopModels& mdl, double w_rad_s, const std::vector<double>& d_start) {
    const Eigen::MatrixXcd n = mu_loop_matrix(mdl, w_rad_s);
    const int p = static_cast<int>(n.rows()) - 1;
    MuPoint r;
    r.w_rad_s = w_rad_s;
    r.rs = std::abs(n(0, 0));
    r.np = n.col(1).tail(p).norm();  // σ̄ of a column
    if (!n.allFinite()) {  // 1 + GK = 0 on the axis: the loop is not stable
        r.rp_upper = r.rp_lower = std::numeric_limits<double>::infinity();
        r.d = {1.0, 1.0};
        return r;
    }
    const MuBound b = mu_bounds(n, {{1, 1}, {p, 1}}, d_start);
    r.rp_upper = b.upper;
    r.rp_lower = b.lower;
    r.d = b.d;
    return r;
}

namespace {

// Maximises f over [lo, hi] (rad/s) by golden-section search in log ω,
// keeping the best of the search and of `best` (the grid maximum).
MuPeak refine_peak(const std::function<double(double)>& f, double lo, double hi, MuPeak best) {
    if (!(lo > 0.0) || !(hi > lo)) return best;
    double a = std::log(lo), b = std::log(hi);
    double x1 = b - kGolden * (b - a), x2 = a + kGolden * (b - a);
    double f1 = f(std::exp(x1)), f2 = f(std::exp(x2));
    for (int i = 0; i < 60 && b - a > 1e-10; ++i) {
        if (f1 > f2) {
            b = x2; x2 = x1; f2 = f1; x1 = b - kGolden * (b - a); f1 = f(std::exp(x1));
        } else {
            a = x1; x1 = x2; f1 = f2; x2 = a + kGolden * (b - a); f2 = f(std::exp(x2));
        }
    }
    if (f1 > best.value) best = {f1, std::exp(x1), 0.0};
    if (f2 > best.value) best = {f2, std::exp(x2), 0.0};
    return best;
}

// The μ test covers a stable N (docs/mu.md): every weight must be stable,
// since its own poles enter N whatever the loop does (the loop's are
// checked from the closed loop's eigenvalues; the model reader refuses
// improper models). Refused naming the weight.
void require_stable_weight(const Zpk& z, const char* name) {
    const bool discrete = is_discrete(z.ts);
    for (const cplx& p : z.poles)
        if (discrete ? !(std::abs(p) < 1.0) : !(p.real() < 0.0)) {
            std::ostringstream t;
            t << name << ": unstable weight (pole " << p.real() << (p.imag() < 0 ? " - " : " + ") << std::abs(p.imag())
              << "j" << (discrete ? ", |z| >= 1" : ", Re >= 0")
              << "): the mu test holds for a stable interconnection only, so every weight must be stable (docs/mu.md)";
            throw std::invalid_argument(t.str());
        }
}

}  // namespace

MuLoopResult mu_loop(const MuLoopModels& mdl) {
    require_stable_weight(mdl.hm, "hm");
    require_stable_weight(mdl.w1, "w1");
    if (mdl.has_w3) require_stable_weight(mdl.w3, "w3");
    if (mdl.has_w2) require_stable_weight(mdl.w2, "w2");
    const double ts = mdl.plant.ts;
    for (const auto& [model, name] : {std::pair{&mdl.controller, "controller"}, std::pair{&mdl.hm, "hm"},
                                      std::pair{&mdl.w1, "w1"}, std::pair{&mdl.w3, "w3"}, std::pair{&mdl.w2, "w2"}}) {
        if ((model == &mdl.w3 && !mdl.has_w3) || (model == &mdl.w2 && !mdl.has_w2)) continue;
        if (model->ts != ts)
            throw std::invalid_argument(std::string(name) + ": all models must be continuous or share the plant's ts");
    }
    MuLoopResult r;
    const FeedbackLoop fl = feedback_loop(zpk2ss(mdl.plant), zpk2ss(mdl.controller));
    r.stability_measure = stability_measure(fl.S);
    r.nominally_stable = is_stable(fl.S);

    std::vector<cplx> crit = critical_points(mdl.plant, mdl.controller);
    for (const Zpk* z : {&mdl.hm, &mdl.w1, mdl.has_w3 ? &mdl.w3 : nullptr, mdl.has_w2 ? &mdl.w2 : nullptr}) {
        if (!z) continue;
        crit.insert(crit.end(), z->poles.begin(), z->poles.end());
        crit.insert(crit.end(), z->zeros.begin(), z->zeros.end());
    }
    const std::vector<cplx> cl = ss_poles(fl.S);
    crit.insert(crit.end(), cl.begin(), cl.end());
    const std::vector<double> grid = analysis_grid(crit, ts);

    std::vector<double> d_prev;
    std::size_t i_rs = 0, i_np = 0, i_rp = 0;
    for (std::size_t i = 0; i < grid.size(); ++i) {
        MuPoint p = mu_loop_point(mdl, grid[i], d_prev);
        d_prev = p.d;
        if (std::isfinite(p.rp_upper) && p.rp_upper > 0.0)
            r.max_gap = std::max(r.max_gap, (p.rp_upper - p.rp_lower) / p.rp_upper);
        r.points.push_back(std::move(p));
        const MuPoint& q = r.points.back();
        if (q.rs > r.points[i_rs].rs) i_rs = i;
        if (q.np > r.points[i_np].np) i_np = i;
        if (q.rp_upper > r.points[i_rp].rp_upper) i_rp = i;
    }
    auto bracket = [&](std::size_t i) {
        return std::pair{grid[i == 0 ? 0 : i - 1], grid[std::min(i + 1, grid.size() - 1)]};
    };
    {
        const auto [lo, hi] = bracket(i_rs);
        r.rs = refine_peak([&](double w) { return std::abs(mu_loop_matrix(mdl, w)(0, 0)); }, lo, hi,
                           {r.points[i_rs].rs, grid[i_rs], r.points[i_rs].rs});
        r.rs.lower = r.rs.value;  // exact for one scalar block
    }
    {
        const auto [lo, hi] = bracket(i_np);
        r.np = refine_peak([&](double w) { return mu_loop_point(mdl, w).np; }, lo, hi,
                           {r.points[i_np].np, grid[i_np], r.points[i_np].np});
        r.np.lower = r.np.value;  // one full block: μ = σ̄
    }
    {
        const auto [lo, hi] = bracket(i_rp);
        const std::vector<double> d0 = r.points[i_rp].d;
        r.rp = refine_peak([&](double w) { return mu_loop_point(mdl, w, d0).rp_upper; }, lo, hi,
                           {r.points[i_rp].rp_upper, grid[i_rp], 0.0});
        if (std::isfinite(r.rp.value)) r.rp.lower = mu_loop_point(mdl, r.rp.w_rad_s, d0).rp_lower;
        else r.rp.lower = r.rp.value;
    }
    return r;
}

}  // namespace piezoloop::design
