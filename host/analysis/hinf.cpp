#include "analysis/hinf.hpp"

#include <algorithm>
#include <cmath>
#include <limits>
#include <numbers>
#include <stdexcept>

#include <Eigen/Eigenvalues>

#include "analysis/margins.hpp"
#include "numeric_constants.hpp"

namespace piezoloop::design {
namespace {

void check_model(const Ss& g, const char* what) {
    const auto n = g.A.rows();
    if (g.A.cols() != n || g.B.size() != n || g.C.size() != n)
        throw std::invalid_argument(std::string(what) + ": A, B, C dimensions disagree");
    if (!g.A.allFinite() || !g.B.allFinite() || !g.C.allFinite() || !std::isfinite(g.D))
        throw std::invalid_argument(std::string(what) + ": non-finite state-space entry");
    if (!(g.ts >= 0.0) || !std::isfinite(g.ts))
        throw std::invalid_argument(std::string(what) + ": ts must be finite and >= 0");
}

void balance_matrix(Eigen::MatrixXd& a, Eigen::Index n_free);
Ss balance_pr(const Ss& g);

// Hamiltonian whose imaginary eigenvalues jω are the frequencies where
// |G(jω)| = γ (γ > |D|): the zeros of γ² - G(-s) G(s).
Eigen::MatrixXd hamiltonian(const Ss& g, double gamma) {
    const auto n = g.A.rows();
    const double r = gamma * gamma - g.D * g.D;
    const Eigen::MatrixXd a = g.A + (g.D / r) * g.B * g.C;
    Eigen::MatrixXd h(2 * n, 2 * n);
    h.topLeftCorner(n, n) = a;
    h.topRightCorner(n, n) = (1.0 / r) * g.B * g.B.transpose();
    h.bottomLeftCorner(n, n) = -(gamma * gamma / r) * g.C.transpose() * g.C;
    h.bottomRightCorner(n, n) = -a.transpose();
    return h;
}

// Sorted non-negative frequencies of the (numerically) imaginary eigenvalues.
// The tolerance is generous: a false detection only costs an extra midpoint
// evaluation (see the certificate argument in hinf.hpp), a missed one would
// stop the iteration early. Genuine crossings have been seen 3e-5 |λ| off
// the axis (Ahmad2020's H_y T: a double pole at −7.5e7 rad/s next to poles
// at 3 rad/s), hence 1e-3.
std::vector<double> imaginary_axis_frequencies(Eigen::MatrixXd h) {
    balance_matrix(h, h.rows());
    Eigen::EigenSolver<Eigen::MatrixXd> es(h, false);
    if (es.info() != Eigen::Success) throw std::runtime_error("hinf_norm: Hamiltonian eigenvalues did not converge");
    const double scale = h.cwiseAbs().rowwise().sum().maxCoeff();
    std::vector<double> w;
    for (Eigen::Index i = 0; i < es.eigenvalues().size(); ++i) {
        const cplx l = es.eigenvalues()[i];
        if (std::abs(l.real()) <= 1e-3 * std::abs(l) + 1e-12 * scale && l.imag() >= 0.0) w.push_back(l.imag());
    }
    std::sort(w.begin(), w.end());
    return w;
}

double golden_max(const SsEvaluator& ev, double lo, double hi, double& best_w, double best) {
    // Maximises |G(jω)| over [lo, hi] in log ω (unimodal near a peak).
    const double phi = (std::sqrt(5.0) - 1.0) / 2.0;
    double a = std::log(lo), b = std::log(hi);
    double x1 = b - phi * (b - a), x2 = a + phi * (b - a);
    double f1 = std::abs(ev.at_s({0.0, std::exp(x1)})), f2 = std::abs(ev.at_s({0.0, std::exp(x2)}));
    for (int i = 0; i < 80 && (b - a) > 1e-13; ++i) {
        if (f1 > f2) {
            b = x2; x2 = x1; f2 = f1; x1 = b - phi * (b - a);
            f1 = std::abs(ev.at_s({0.0, std::exp(x1)}));
        } else {
            a = x1; x1 = x2; f1 = f2; x2 = a + phi * (b - a);
            f2 = std::abs(ev.at_s({0.0, std::exp(x2)}));
        }
    }
    const double w = f1 > f2 ? std::exp(x1) : std::exp(x2);
    const double f = std::max(f1, f2);
    if (f > best) {
        best_w = w;
        return f;
    }
    return best;
}

// Continuous-time level-set iteration on a balanced, frequency-normalised
// model. Returns sup |G(jω)| over ω in [0, ∞] (ω in the model's own units).
HinfResult hinf_continuous(const Ss& g, double tol) {
    HinfResult out;
    const auto n = g.A.rows();
    const SsEvaluator ev(g);
    // Lower bound: ω = 0 (if not a pole), ω → ∞, and each pole's magnitude.
    double lb = std::abs(g.D);
    double w_lb = kInf;
    out.peak_at_infinity = true;
    auto consider = [&](double w) {
        const double v = std::abs(ev.at_s({0.0, w}));
        if (v > lb) {
            lb = v;
            w_lb = w;
            out.peak_at_infinity = false;
        }
    };
    consider(0.0);
    for (const cplx& p : ss_poles(g)) {
        if (std::abs(p.real()) == 0.0 && p.imag() >= 0.0) {  // pole on the axis
            out.norm = out.lower = out.upper = kInf;
            out.peak_w_rad_s = p.imag();
            out.peak_at_infinity = false;
            return out;
        }
        consider(std::abs(p));
        consider(std::abs(p.imag()));
    }
    if (!std::isfinite(lb)) {
        out.norm = out.lower = out.upper = kInf;
        out.peak_w_rad_s = w_lb;
        return out;
    }
    if (lb == 0.0 && n == 0) {
        out.peak_w_rad_s = 0.0;
        return out;
    }
    // Work on G / lb0 so that γ ~ 1 and the Hamiltonian's blocks B B^T / r
    // and C^T C γ² / r stay O(|B|^2) whatever the model's gain (a 1e-12 gain
    // would otherwise put 1e24 next to 1 and hide the imaginary eigenvalues).
    // G = 0 at every point tried (a zero-gain model, C = 0 or B = 0): scale on
    // the largest entry instead; lb stays 0, the value actually attained, and
    // the first level tested is a small fraction of that scale, so a model
    // that is zero everywhere gets the norm 0 with that level as its bound.
    const double scale = lb > 0.0 ? lb
                                  : std::max({g.B.cwiseAbs().maxCoeff(), g.C.cwiseAbs().maxCoeff(),
                                              std::numeric_limits<double>::min()});
    constexpr double kFirstLevelIfZero = 1e-9;
    Ss gs = g;
    gs.C /= scale;
    gs.D /= scale;
    const SsEvaluator evs(gs);
    lb /= scale;
    double upper = kInf;
    for (int it = 0; it < 60; ++it) {
        out.iterations = it + 1;
        const double gamma = lb > 0.0 ? (1.0 + 2.0 * tol) * lb : kFirstLevelIfZero;
        const std::vector<double> w = imaginary_axis_frequencies(hamiltonian(gs, gamma));
        if (w.empty()) {
            upper = gamma;
            break;
        }
        // Interval endpoints: the crossings, plus 0 when their number is odd
        // (the level set would then start at ω = 0).
        std::vector<double> pts;
        if (w.size() % 2 == 1) pts.push_back(0.0);
        pts.insert(pts.end(), w.begin(), w.end());
        double best = lb, w_best = w_lb;
        for (std::size_t i = 0; i + 1 < pts.size(); ++i) {
            const double a = pts[i], b = pts[i + 1];
            const double m = a > 0.0 ? std::sqrt(a * b) : 0.5 * b;
            const double v = std::abs(evs.at_s({0.0, m}));
            if (v > best) {
                best = v;
                w_best = m;
            }
        }
        if (!(best > gamma)) {  // no interval rises above γ: certified
            upper = gamma;
            break;
        }
        lb = best;
        w_lb = w_best;
        out.peak_at_infinity = false;
    }
    if (!std::isfinite(upper))  // did not converge in 60 steps (never seen)
        throw std::runtime_error("hinf_norm: level-set iteration did not converge");
    // Safety net: a crossing eigenvalue pushed further off the axis than the
    // tolerance would end the iteration early. The analysis grid (200 points
    // per decade, clustered at lightly damped poles) must not beat the
    // bound; if it does, the result becomes that grid maximum, refined, and
    // is marked uncertified.
    {
        std::vector<cplx> poles = ss_poles(gs);
        double gbest = 0.0, gw = 0.0;
        for (double w : analysis_grid(poles, 0.0)) {
            const double v = std::abs(evs.at_s({0.0, w}));
            if (v > gbest) {
                gbest = v;
                gw = w;
            }
        }
        if (gbest > upper * (1.0 + 1e-9)) {
            out.certified = false;
            lb = gbest;
            w_lb = gw;
            out.peak_at_infinity = false;
            upper = kInf;
        }
    }
    if (std::isfinite(w_lb) && w_lb > 0.0) lb = golden_max(evs, w_lb / 1.01, w_lb * 1.01, w_lb, lb);
    if (!std::isfinite(upper)) upper = lb;
    out.norm = out.lower = lb * scale;
    out.upper = std::max(upper, lb) * scale;
    out.peak_w_rad_s = w_lb;
    return out;
}

// Parlett–Reinsch: scales row/column pairs 0..n_free-1 of a by powers of 2
// (exact) until their off-diagonal norms are within a factor 2 of each other.
void balance_matrix(Eigen::MatrixXd& a, Eigen::Index n_free) {
    bool done = false;
    for (int sweep = 0; sweep < 200 && !done; ++sweep) {
        done = true;
        for (Eigen::Index i = 0; i < n_free; ++i) {
            const double c = a.col(i).cwiseAbs().sum() - std::abs(a(i, i));
            const double r = a.row(i).cwiseAbs().sum() - std::abs(a(i, i));
            if (c == 0.0 || r == 0.0) continue;
            double f = 1.0;
            double cc = c, rr = r;
            while (cc < rr / 2.0) { cc *= 2.0; rr /= 2.0; f *= 2.0; }
            while (cc >= rr * 2.0) { cc /= 2.0; rr *= 2.0; f /= 2.0; }
            if ((cc + rr) < 0.95 * (c + r)) {
                done = false;
                a.col(i) *= f;
                a.row(i) /= f;
            }
        }
    }
}

Ss balance_pr(const Ss& g) {
    Ss out = g;
    const auto n = g.A.rows();
    if (n == 0) return out;
    // Balance M = [[A, B], [C, 0]] with the last index (input and output)
    // kept fixed. Including B and C matters: in a cascade the last state may
    // feed only the output, and balancing A alone would leave it 1e13 off.
    Eigen::MatrixXd a(n + 1, n + 1);
    a.topLeftCorner(n, n) = g.A;
    a.topRightCorner(n, 1) = g.B;
    a.bottomLeftCorner(1, n) = g.C;
    a(n, n) = 0.0;
    balance_matrix(a, n);
    out.A = a.topLeftCorner(n, n);  // D^-1 A D
    out.B = a.topRightCorner(n, 1);  // D^-1 B
    out.C = a.bottomLeftCorner(1, n);  // C D
    // Equalise the input and output scale.
    const double nb = out.B.norm(), nc = out.C.norm();
    if (nb > 0.0 && nc > 0.0) {
        const double beta = std::sqrt(nc / nb);
        out.B *= beta;
        out.C /= beta;
    }
    return out;
}

}  // namespace

SsEvaluator::SsEvaluator(const Ss& model) : d_(model.D), ts_(model.ts) {
    check_model(model, "model");
    const auto n = model.A.rows();
    if (n == 0) return;
    // Balance first: a cascade of sections can couple states whose scales
    // differ by 1e14, and the orthogonal Hessenberg reduction would mix them.
    const Ss g = balance_pr(model);
    Eigen::HessenbergDecomposition<Eigen::MatrixXd> hd(g.A);
    h_ = hd.matrixH();
    const Eigen::MatrixXd q = hd.matrixQ();
    b_ = q.transpose() * g.B;
    c_ = g.C * q;
}

cplx SsEvaluator::at_s(cplx s) const {
    const auto n = h_.rows();
    if (n == 0) return d_;
    // Solve (sI - H) x = b: Gaussian elimination with partial pivoting on an
    // upper Hessenberg matrix only ever swaps neighbouring rows.
    Eigen::MatrixXcd m = -h_.cast<cplx>();
    m.diagonal().array() += s;
    Eigen::VectorXcd x = b_.cast<cplx>();
    for (Eigen::Index k = 0; k + 1 < n; ++k) {
        if (std::abs(m(k + 1, k)) > std::abs(m(k, k))) {
            m.row(k).segment(k, n - k).swap(m.row(k + 1).segment(k, n - k));
            std::swap(x(k), x(k + 1));
        }
        if (m(k, k) == cplx(0.0)) return {kInf, 0.0};
        const cplx f = m(k + 1, k) / m(k, k);
        if (f != cplx(0.0)) {
            m.row(k + 1).segment(k, n - k) -= f * m.row(k).segment(k, n - k);
            x(k + 1) -= f * x(k);
        }
    }
    for (Eigen::Index k = n - 1; k >= 0; --k) {
        if (m(k, k) == cplx(0.0)) return {kInf, 0.0};
        cplx acc = x(k);
        for (Eigen::Index j = k + 1; j < n; ++j) acc -= m(k, j) * x(j);
        x(k) = acc / m(k, k);
    }
    cplx y = d_;
    for (Eigen::Index k = 0; k < n; ++k) y += c_(k) * x(k);
    return y;
}

cplx SsEvaluator::at_w(double w_rad_s) const {
    if (is_discrete(ts_)) return at_s(std::polar(1.0, w_rad_s * ts_));
    return at_s({0.0, w_rad_s});
}

std::vector<cplx> ss_poles(const Ss& g) {
    check_model(g, "model");
    if (g.A.rows() == 0) return {};
    Eigen::EigenSolver<Eigen::MatrixXd> es(balance_pr(g).A, false);
    if (es.info() != Eigen::Success) throw std::runtime_error("poles: eigenvalues did not converge");
    std::vector<cplx> p(es.eigenvalues().data(), es.eigenvalues().data() + es.eigenvalues().size());
    return p;
}

double stability_measure(const Ss& g) {
    const std::vector<cplx> p = ss_poles(g);
    double m = is_discrete(g.ts) ? 0.0 : -kInf;
    for (const cplx& z : p) m = std::max(m, is_discrete(g.ts) ? std::abs(z) : z.real());
    return m;
}

bool is_stable(const Ss& g) {
    const double m = stability_measure(g);
    return is_discrete(g.ts) ? m < 1.0 : m < 0.0;
}

Ss bilinear_to_continuous(const Ss& g) {
    check_model(g, "model");
    const auto n = g.A.rows();
    Ss c;
    c.ts = 0.0;
    if (n == 0) {
        c.D = g.D;
        return c;
    }
    const Eigen::MatrixXd ipa = Eigen::MatrixXd::Identity(n, n) + g.A;
    Eigen::PartialPivLU<Eigen::MatrixXd> lu(ipa);
    if (std::abs(lu.determinant()) == 0.0 || !std::isfinite(lu.rcond()) || lu.rcond() < 1e-14)
        throw std::invalid_argument("model has a pole at z = -1 (bilinear map undefined)");
    const Eigen::MatrixXd inv = lu.inverse();
    c.A = inv * (g.A - Eigen::MatrixXd::Identity(n, n));
    c.B = std::sqrt(2.0) * inv * g.B;
    c.C = std::sqrt(2.0) * g.C * inv;
    c.D = g.D - (g.C * inv * g.B)(0, 0);
    return c;
}

HinfResult hinf_norm(const Ss& g, double rel_tol) {
    check_model(g, "model");
    if (!(rel_tol >= 1e-12 && rel_tol <= 1e-2)) throw std::invalid_argument("hinf_norm: rel_tol must be in [1e-12, 1e-2]");
    const bool discrete = is_discrete(g.ts);
    const bool stable = is_stable(g);
    HinfResult r;
    if (discrete) {
        // A pole on the unit circle: infinite peak.
        for (const cplx& p : ss_poles(g))
            if (std::abs(std::abs(p) - 1.0) == 0.0) {
                r.norm = r.lower = r.upper = kInf;
                r.stable = false;
                r.peak_w_rad_s = std::abs(std::arg(p)) / g.ts;
                r.peak_Hz = r.peak_w_rad_s / (2.0 * std::numbers::pi);
                return r;
            }
        const Ss c = balance_pr(bilinear_to_continuous(g));
        r = hinf_continuous(c, rel_tol);
        // ω_c = tan(θ/2); ω_c → ∞ is θ = π (Nyquist).
        const double theta = r.peak_at_infinity ? std::numbers::pi : 2.0 * std::atan(r.peak_w_rad_s);
        r.peak_at_infinity = false;
        r.peak_w_rad_s = theta / g.ts;
    } else {
        Ss b = balance_pr(g);
        // Normalise the frequency axis: s = w0 s'. A' = A / w0, B' = B / w0.
        double w0 = 1.0;
        if (b.A.rows() > 0) {
            double lo = kInf, hi = 0.0;
            for (const cplx& p : ss_poles(b)) {
                const double m = std::abs(p);
                if (m > 0.0) {
                    lo = std::min(lo, m);
                    hi = std::max(hi, m);
                }
            }
            if (hi > 0.0) w0 = std::sqrt(lo * hi);
        }
        b.A /= w0;
        b.B /= w0;
        r = hinf_continuous(b, rel_tol);
        r.peak_w_rad_s *= w0;
    }
    r.stable = stable;
    r.peak_Hz = r.peak_w_rad_s / (2.0 * std::numbers::pi);
    return r;
}

}  // namespace piezoloop::design
