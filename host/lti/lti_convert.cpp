#include "lti/lti_convert.hpp"
#include "lti/text.hpp"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <limits>
#include <stdexcept>
#include <string>

#include <Eigen/Eigenvalues>


namespace piezoloop::design {
namespace {

// Roots closer to an exact conjugate than this (relative to their
// magnitude) are taken as one conjugate pair; a root whose imaginary part is
// below it is taken as real. Far above double rounding (1e-16) and far below
// any distinction a model file could mean.
constexpr double kConjugateTol = 1e-9;

// In ss2zpk, a rotated output coefficient below kDeflateTol * n * |C| is
// zero up to the rounding of the rotation (a few n eps |C|): 100 eps.
constexpr double kDeflateTol = 100.0 * std::numeric_limits<double>::epsilon();

[[noreturn]] void fail(const std::string& what) { throw std::invalid_argument(what); }

bool all_finite(const std::vector<double>& v) {
    return std::all_of(v.begin(), v.end(), [](double x) { return std::isfinite(x); });
}

// Parlett–Reinsch balancing of a square matrix by powers of two; returns
// the diagonal d with A <- D^-1 A D.
// If `fixed_last`, the last row/column takes part in the norms but is never
// scaled itself (used for [A B; C 0], whose last index is the input/output).
Eigen::VectorXd balance_in_place(Eigen::MatrixXd& a, bool fixed_last = false) {
    const Eigen::Index n = a.rows();
    const Eigen::Index scaled = fixed_last ? n - 1 : n;
    Eigen::VectorXd d = Eigen::VectorXd::Ones(n);
    bool converged = false;
    for (int sweep = 0; !converged && sweep < 100; ++sweep) {
        converged = true;
        for (Eigen::Index i = 0; i < scaled; ++i) {
            double c = 0.0, r = 0.0;
            for (Eigen::Index j = 0; j < n; ++j) {
                if (j == i) continue;
                c += std::fabs(a(j, i));
                r += std::fabs(a(i, j));
            }
            if (c == 0.0 || r == 0.0) continue;
            const double s = c + r;
            double f = 1.0;
            double g = r / 2.0;
            while (c < g) {
                f *= 2.0;
                c *= 4.0;
            }
            g = r * 2.0;
            while (c >= g) {
                f /= 2.0;
                c /= 4.0;
            }
            if ((c + r) / f < 0.95 * s) {
                converged = false;
                d(i) *= f;
                a.row(i) /= f;
                a.col(i) *= f;
            }
        }
    }
    return d;
}

std::vector<cplx> eigenvalues(const Eigen::MatrixXd& m) {
    std::vector<cplx> out;
    if (m.rows() == 0) return out;
    Eigen::EigenSolver<Eigen::MatrixXd> es(m, false);
    if (es.info() != Eigen::Success) fail("eigenvalue computation did not converge");
    for (Eigen::Index i = 0; i < m.rows(); ++i) out.push_back(es.eigenvalues()(i));
    return out;
}

// Value and derivative of a real polynomial (descending) at t.
void horner(const std::vector<double>& q, cplx t, cplx& f, cplx& fp) {
    f = 0.0;
    fp = 0.0;
    for (double c : q) {
        fp = fp * t + f;
        f = f * t + c;
    }
}

// Guarded Newton polishing of one root of q: a step is taken only if it
// lowers |q| and stays within half the distance to the nearest other root
// (so it cannot jump to a neighbour).
cplx polish(const std::vector<double>& q, cplx t, double neighbour_distance) {
    cplx f, fp;
    horner(q, t, f, fp);
    for (int it = 0; it < 4; ++it) {
        if (fp == 0.0 || f == 0.0) break;
        const cplx step = f / fp;
        if (!(std::abs(step) < 0.5 * neighbour_distance)) break;
        const cplx t2 = t - step;
        cplx f2, fp2;
        horner(q, t2, f2, fp2);
        if (!(std::abs(f2) < std::abs(f))) break;
        t = t2;
        f = f2;
        fp = fp2;
    }
    return t;
}

bool root_less(cplx a, cplx b) {
    const double ma = std::abs(a), mb = std::abs(b);
    if (ma != mb) return ma < mb;
    if (a.real() != b.real()) return a.real() < b.real();
    return std::fabs(a.imag()) < std::fabs(b.imag());
}

std::vector<cplx> assemble(std::vector<double> real, std::vector<cplx> upper) {
    std::vector<cplx> units;
    for (double r : real) units.emplace_back(r, 0.0);
    for (cplx u : upper) units.push_back(u);
    std::sort(units.begin(), units.end(), root_less);
    std::vector<cplx> out;
    for (cplx u : units) {
        out.push_back(u);
        if (u.imag() != 0.0) out.push_back(std::conj(u));
    }
    return out;
}

std::vector<double> strip_leading_zeros(const std::vector<double>& p) {
    size_t i = 0;
    while (i < p.size() && p[i] == 0.0) ++i;
    return std::vector<double>(p.begin() + static_cast<std::ptrdiff_t>(i), p.end());
}

void check_ss(const Ss& ss) {
    const Eigen::Index n = ss.A.rows();
    if (ss.A.cols() != n) fail("ss.A: must be square");
    if (ss.B.size() != n) fail("ss.B: must have as many rows as A");
    if (ss.C.size() != n) fail("ss.C: must have as many columns as A");
    if (!ss.A.allFinite() || !ss.B.allFinite() || !ss.C.allFinite() || !std::isfinite(ss.D))
        fail("ss: entries must be finite");
    if (!(ss.ts >= 0.0) || !std::isfinite(ss.ts)) fail("ss.ts: must be finite and >= 0");
}

void check_ts(double a, double b, const char* what) {
    if (a != b) fail(cat(what, ": models must have the same ts (", fmt(a, 17), " vs ", fmt(b, 17), ")"));
}

// ---- zpk2ss building blocks ------------------------------------------------

struct Block {
    Eigen::MatrixXd A;
    Eigen::VectorXd B;
    Eigen::RowVectorXd C;
    double D = 0.0;
};

// Splits C between B and C so that both have comparable size.
void share(Block& b) {
    const double c = b.C.norm();
    if (c > 0.0 && std::isfinite(c)) {
        const double beta = std::ldexp(1.0, std::ilogb(c) / 2);  // power of two, exact
        b.B *= beta;
        b.C /= beta;
    }
}

// One cascade section: poles (one real, one complex pair given by its +imag
// member, or two reals), zeros (at most as many as poles) and a gain.
struct Section {
    std::vector<cplx> poles;  // 1 real, {pair member}, or 2 reals
    bool pole_pair = false;
    std::vector<double> real_zeros;
    bool has_zero_pair = false;
    cplx zero_pair{};
    int order() const { return pole_pair ? 2 : static_cast<int>(poles.size()); }
    int zero_count() const { return static_cast<int>(real_zeros.size()) + (has_zero_pair ? 2 : 0); }
    int free_slots() const { return order() - zero_count(); }
    double distance(cplx z) const {
        double d = std::numeric_limits<double>::infinity();
        for (cplx p : poles) d = std::min({d, std::abs(p - z), std::abs(std::conj(p) - z)});
        return d;
    }
    // Monic numerator prod(s - z) in ascending-size form {b2, b1, b0} for the
    // second-order case, {b1, b0} for the first-order case.
    void numerator(double& b2, double& b1, double& b0) const {
        if (has_zero_pair) {
            b2 = 1.0;
            b1 = -2.0 * zero_pair.real();
            b0 = std::norm(zero_pair);
        } else if (real_zeros.size() == 2) {
            b2 = 1.0;
            b1 = -(real_zeros[0] + real_zeros[1]);
            b0 = real_zeros[0] * real_zeros[1];
        } else if (real_zeros.size() == 1) {
            b2 = 0.0;
            b1 = 1.0;
            b0 = -real_zeros[0];
        } else {
            b2 = 0.0;
            b1 = 0.0;
            b0 = 1.0;
        }
    }
    cplx value(cplx s) const {
        cplx v = 1.0;
        for (double z : real_zeros) v *= s - z;
        if (has_zero_pair) v *= (s - zero_pair) * (s - std::conj(zero_pair));
        for (cplx p : poles) {
            v /= s - p;
            if (pole_pair) v /= s - std::conj(p);
        }
        return v;
    }
    double natural_frequency() const {
        double logsum = 0.0;
        int count = 0;
        auto add = [&](double m) {
            if (m > 0.0) {
                logsum += std::log(m);
                ++count;
            }
        };
        for (cplx p : poles) add(std::abs(p));
        for (double z : real_zeros) add(std::fabs(z));
        if (has_zero_pair) add(std::abs(zero_pair));
        return count > 0 ? std::exp(logsum / count) : 1.0;
    }
};

Block section_block(const Section& sec, double k) {
    Block b;
    double n2, n1, n0;
    sec.numerator(n2, n1, n0);
    if (sec.order() == 1) {
        const double p = sec.poles[0].real();
        // k (n1 s + n0) / (s - p) = k n1 + k (n0 + n1 p) / (s - p)
        b.A = Eigen::MatrixXd::Constant(1, 1, p);
        b.B = Eigen::VectorXd::Ones(1);
        b.C = Eigen::RowVectorXd::Constant(1, k * (n0 + n1 * p));
        b.D = k * n1;
        share(b);
        return b;
    }
    // Second order, den = s^2 + a1 s + a0. Strictly proper remainder of
    // k (n2 s^2 + n1 s + n0) / den:  k ((n1 - n2 a1) s + (n0 - n2 a0)).
    double a1, a0;
    b.A.resize(2, 2);
    b.B = Eigen::Vector2d(1.0, 0.0);
    b.C.resize(2);
    if (sec.pole_pair) {
        const cplx p = sec.poles[0];
        a1 = -2.0 * p.real();
        const double w0 = std::abs(p);
        a0 = w0 * w0;
        const double r1 = k * (n1 - n2 * a1);
        // n0 - n2 a0 with n0 = |z|^2 when both zeros form a pair: factored as
        // (|z| - |p|)(|z| + |p|) so a notch's zeros near its poles keep
        // their small difference.
        double r0;
        if (sec.has_zero_pair)
            r0 = k * (std::abs(sec.zero_pair) - w0) * (std::abs(sec.zero_pair) + w0);
        else
            r0 = k * (n0 - n2 * a0);
        // x1' = -a1 x1 - w0 x2 + u, x2' = w0 x1:  X1 = s U / den, X2 = w0 U / den.
        b.A << -a1, -w0, w0, 0.0;
        b.C << r1, r0 / w0;
    } else {
        const double p1 = sec.poles[0].real(), p2 = sec.poles[1].real();
        a1 = -(p1 + p2);
        a0 = p1 * p2;
        const double r1 = k * (n1 - n2 * a1);
        const double r0 = k * (n0 - n2 * a0);
        const double sigma = a0 != 0.0 ? std::sqrt(std::fabs(a0)) : 1.0;
        // x1' = p1 x1 + u, x2' = sigma x1 + p2 x2:
        // X1 = U / (s - p1), X2 = sigma U / den; r1 s + r0 = c1 (s - p2) + c2 sigma.
        b.A << p1, 0.0, sigma, p2;
        b.C << r1, (r0 + r1 * p2) / sigma;
    }
    b.D = k * n2;
    share(b);
    return b;
}

Block cascade(const Block& first, const Block& second) {
    const Eigen::Index n1 = first.A.rows(), n2 = second.A.rows();
    Block out;
    out.A = Eigen::MatrixXd::Zero(n1 + n2, n1 + n2);
    out.A.topLeftCorner(n1, n1) = first.A;
    out.A.bottomRightCorner(n2, n2) = second.A;
    out.A.bottomLeftCorner(n2, n1) = second.B * first.C;
    out.B.resize(n1 + n2);
    out.B.head(n1) = first.B;
    out.B.tail(n2) = second.B * first.D;
    out.C.resize(n1 + n2);
    out.C.head(n1) = second.D * first.C;
    out.C.tail(n2) = second.C;
    out.D = second.D * first.D;
    return out;
}

}  // namespace

// ---- polynomials ------------------------------------------------------------

std::vector<cplx> poly_roots(const std::vector<double>& p_in) {
    if (!all_finite(p_in)) fail("polynomial: coefficients must be finite");
    std::vector<double> p = strip_leading_zeros(p_in);
    if (p.empty()) fail("polynomial: all coefficients are zero");
    // Exact zero roots first.
    size_t zero_roots = 0;
    while (p.size() > 1 && p.back() == 0.0) {
        p.pop_back();
        ++zero_roots;
    }
    const int n = static_cast<int>(p.size()) - 1;
    std::vector<double> real;
    std::vector<cplx> upper;
    if (n >= 1) {
        // t = s / alpha, alpha = 2^e close to the geometric mean of the root
        // magnitudes, makes the monic coefficients q_k = p_k / (p_0 alpha^k)
        // of comparable size.
        const int e = static_cast<int>(
            std::lround((std::log2(std::fabs(p[static_cast<size_t>(n)])) - std::log2(std::fabs(p[0]))) / n));
        std::vector<double> q(static_cast<size_t>(n) + 1);
        for (int k = 0; k <= n; ++k) q[static_cast<size_t>(k)] = std::ldexp(p[static_cast<size_t>(k)] / p[0], -e * k);
        Eigen::MatrixXd comp = Eigen::MatrixXd::Zero(n, n);
        for (int k = 0; k < n; ++k) comp(0, k) = -q[static_cast<size_t>(k) + 1];
        for (int k = 1; k < n; ++k) comp(k, k - 1) = 1.0;
        balance_in_place(comp);
        const std::vector<cplx> t = eigenvalues(comp);
        // Polish real roots and the +imag member of each pair (the real
        // Schur form gives exact conjugates; keep them exact).
        for (size_t i = 0; i < t.size(); ++i) {
            if (t[i].imag() < 0.0) continue;
            double nearest = std::numeric_limits<double>::infinity();
            for (size_t j = 0; j < t.size(); ++j)
                if (j != i) nearest = std::min(nearest, std::abs(t[j] - t[i]));
            cplx r = polish(q, t[i], nearest);
            r = std::ldexp(1.0, e) * r;
            if (t[i].imag() == 0.0)
                real.push_back(r.real());
            else
                upper.emplace_back(r.real(), std::fabs(r.imag()));
        }
    }
    for (size_t i = 0; i < zero_roots; ++i) real.push_back(0.0);
    return assemble(real, upper);
}

std::vector<double> poly_mul(const std::vector<double>& a, const std::vector<double>& b) {
    if (a.empty() || b.empty()) return {};
    std::vector<double> out(a.size() + b.size() - 1, 0.0);
    for (size_t i = 0; i < a.size(); ++i)
        for (size_t j = 0; j < b.size(); ++j) out[i + j] += a[i] * b[j];
    return out;
}

void split_conjugates(const std::vector<cplx>& roots, std::vector<double>& real, std::vector<cplx>& upper,
                      const char* what) {
    real.clear();
    upper.clear();
    std::vector<bool> used(roots.size(), false);
    for (size_t i = 0; i < roots.size(); ++i) {
        const cplx r = roots[i];
        if (!std::isfinite(r.real()) || !std::isfinite(r.imag()))
            fail(cat(what, "[", std::to_string(i), "]: must be finite"));
    }
    for (size_t i = 0; i < roots.size(); ++i) {
        if (used[i]) continue;
        const cplx r = roots[i];
        used[i] = true;
        if (std::fabs(r.imag()) <= kConjugateTol * std::abs(r)) {
            real.push_back(r.real());
            continue;
        }
        size_t best = roots.size();
        double best_d = std::numeric_limits<double>::infinity();
        for (size_t j = 0; j < roots.size(); ++j) {
            if (used[j]) continue;
            const double d = std::abs(roots[j] - std::conj(r));
            if (d <= kConjugateTol * std::abs(r) && d < best_d) {
                best = j;
                best_d = d;
            }
        }
        if (best == roots.size())
            fail(cat(what, "[", std::to_string(i), "]: complex root (", fmt(r.real(), 17), ", ", fmt(r.imag(), 17),
                     ") has no complex-conjugate partner (a real model needs both)"));
        used[best] = true;
        const cplx o = roots[best];
        upper.emplace_back(0.5 * (r.real() + o.real()), 0.5 * (std::fabs(r.imag()) + std::fabs(o.imag())));
    }
}

std::vector<cplx> canonical_roots(const std::vector<cplx>& roots, const char* what) {
    std::vector<double> real;
    std::vector<cplx> upper;
    split_conjugates(roots, real, upper, what);
    return assemble(real, upper);
}

std::vector<double> poly_from_roots(const std::vector<cplx>& roots) {
    std::vector<double> real;
    std::vector<cplx> upper;
    split_conjugates(roots, real, upper, "roots");
    std::vector<double> p{1.0};
    for (cplx u : upper) p = poly_mul(p, {1.0, -2.0 * u.real(), std::norm(u)});
    for (double r : real) p = poly_mul(p, {1.0, -r});
    return p;
}

// ---- conversions --------------------------------------------------------------

Zpk tf2zpk(const Tf& tf) {
    if (tf.den.empty()) fail("tf.den: must not be empty");
    if (tf.num.empty()) fail("tf.num: must not be empty");
    for (size_t i = 0; i < tf.den.size(); ++i)
        if (!std::isfinite(tf.den[i])) fail(cat("tf.den[", std::to_string(i), "]: must be finite"));
    for (size_t i = 0; i < tf.num.size(); ++i)
        if (!std::isfinite(tf.num[i])) fail(cat("tf.num[", std::to_string(i), "]: must be finite"));
    if (tf.den[0] == 0.0) fail("tf.den[0]: leading coefficient must be non-zero");
    if (!std::isfinite(tf.ts) || tf.ts < 0.0) fail("tf.ts: must be finite and >= 0");
    Zpk out;
    out.ts = tf.ts;
    out.poles = poly_roots(tf.den);
    const std::vector<double> num = strip_leading_zeros(tf.num);
    if (num.empty()) {
        out.gain = 0.0;
        return out;
    }
    out.zeros = poly_roots(num);
    out.gain = num[0] / tf.den[0];
    return out;
}

Tf zpk2tf(const Zpk& zpk) {
    if (!std::isfinite(zpk.gain)) fail("zpk.gain: must be finite");
    std::vector<double> real;
    std::vector<cplx> upper;
    split_conjugates(zpk.zeros, real, upper, "zpk.zeros");
    split_conjugates(zpk.poles, real, upper, "zpk.poles");
    Tf out;
    out.ts = zpk.ts;
    out.den = poly_from_roots(zpk.poles);
    if (zpk.gain == 0.0) {
        out.num = {0.0};
    } else {
        out.num = poly_from_roots(zpk.zeros);
        for (double& c : out.num) c *= zpk.gain;
    }
    return out;
}

Ss zpk2ss(const Zpk& zpk) {
    if (!std::isfinite(zpk.gain)) fail("zpk.gain: must be finite");
    if (!std::isfinite(zpk.ts) || zpk.ts < 0.0) fail("zpk.ts: must be finite and >= 0");
    std::vector<double> zr, pr;
    std::vector<cplx> zc, pc;
    split_conjugates(zpk.zeros, zr, zc, "zpk.zeros");
    split_conjugates(zpk.poles, pr, pc, "zpk.poles");
    if (zpk.zeros.size() > zpk.poles.size())
        fail(cat("zpk: improper model (", std::to_string(zpk.zeros.size()), " zeros, ",
                 std::to_string(zpk.poles.size()), " poles) has no state-space realisation"));

    std::vector<Section> sections;
    for (cplx p : pc) {
        Section s;
        s.poles = {p};
        s.pole_pair = true;
        sections.push_back(s);
    }
    // Complex zero pairs, nearest to a complex pole pair first, each to the
    // nearest free second-order section; if none is free, to a new section
    // made of the two real poles nearest to it.
    std::sort(zc.begin(), zc.end(), [&](cplx a, cplx b) {
        auto nearest = [&](cplx z) {
            double d = std::numeric_limits<double>::infinity();
            for (cplx p : pc) d = std::min(d, std::abs(p - z));
            return d;
        };
        const double da = nearest(a), db = nearest(b);
        return da != db ? da < db : root_less(a, b);
    });
    std::sort(pr.begin(), pr.end());
    for (cplx z : zc) {
        Section* best = nullptr;
        for (Section& s : sections)
            if (s.order() == 2 && s.zero_count() == 0 && (best == nullptr || s.distance(z) < best->distance(z)))
                best = &s;
        if (best == nullptr) {
            Section s;
            for (int k = 0; k < 2; ++k) {
                auto it = std::min_element(pr.begin(), pr.end(), [&](double a, double b) {
                    return std::abs(cplx(a) - z) < std::abs(cplx(b) - z);
                });
                s.poles.emplace_back(*it, 0.0);
                pr.erase(it);
            }
            sections.push_back(s);
            best = &sections.back();
        }
        best->has_zero_pair = true;
        best->zero_pair = z;
    }
    for (double p : pr) {
        Section s;
        s.poles = {cplx(p, 0.0)};
        sections.push_back(s);
    }
    std::sort(zr.begin(), zr.end(), [](double a, double b) { return std::fabs(a) < std::fabs(b); });
    for (double z : zr) {
        Section* best = nullptr;
        for (Section& s : sections)
            if (s.free_slots() > 0 && (best == nullptr || s.distance(z) < best->distance(z))) best = &s;
        best->real_zeros.push_back(z);  // a free slot exists: #zeros <= #poles
    }

    Ss out;
    out.ts = zpk.ts;
    if (sections.empty()) {
        out.A.resize(0, 0);
        out.B.resize(0);
        out.C.resize(0);
        out.D = zpk.gain;
        return out;
    }
    // Each section normalised to magnitude 1 at s = j w0 (w0: geometric mean
    // of its root magnitudes; only a scaling, so the same rule serves
    // discrete models), then the gain spread geometrically over the sections.
    const size_t m = sections.size();
    std::vector<double> g(m);
    double log_total = std::log(std::fabs(zpk.gain));
    for (size_t i = 0; i < m; ++i) {
        const double w = sections[i].natural_frequency();
        const double v = std::abs(sections[i].value(cplx(0.0, w)));
        g[i] = (std::isfinite(v) && v > 0.0) ? v : 1.0;
        log_total += std::log(g[i]);
    }
    const double c = std::exp(log_total / static_cast<double>(m));
    Block total;
    for (size_t i = 0; i < m; ++i) {
        double k = zpk.gain == 0.0 ? (i == 0 ? 0.0 : 1.0 / g[i]) : c / g[i];
        if (i == 0 && zpk.gain < 0.0) k = -k;
        const Block b = section_block(sections[i], k);
        total = i == 0 ? b : cascade(total, b);
    }
    // Correct the rounding of exp/log in the spread gain exactly at the end
    // (ratio of the intended and realised leading gains).
    out.A = total.A;
    out.B = total.B;
    out.C = total.C;
    out.D = total.D;
    if (zpk.gain != 0.0) {
        double realised = 1.0;
        for (size_t i = 0; i < m; ++i) realised *= (c / g[i]);
        const double fix = std::fabs(zpk.gain) / realised;
        out.C *= fix;
        out.D *= fix;
    }
    return out;
}

Ss tf2ss(const Tf& tf) { return zpk2ss(tf2zpk(tf)); }

Ss balance(const Ss& ss) {
    check_ss(ss);
    Ss out = ss;
    const Eigen::VectorXd d = balance_in_place(out.A);
    out.B = ss.B.cwiseQuotient(d);
    out.C = ss.C.cwiseProduct(d.transpose());
    return out;
}

Ss balance_system(const Ss& ss) {
    check_ss(ss);
    const Eigen::Index n = ss.A.rows();
    Eigen::MatrixXd m = Eigen::MatrixXd::Zero(n + 1, n + 1);
    m.topLeftCorner(n, n) = ss.A;
    m.topRightCorner(n, 1) = ss.B;
    m.bottomLeftCorner(1, n) = ss.C;
    balance_in_place(m, true);
    Ss out = ss;
    out.A = m.topLeftCorner(n, n);
    out.B = m.topRightCorner(n, 1);
    out.C = m.bottomLeftCorner(1, n);
    return out;
}

Zpk ss2zpk(const Ss& ss) {
    check_ss(ss);
    Zpk out;
    out.ts = ss.ts;
    // Poles from A balanced alone (best for eig); zeros from the system
    // balanced as a whole, [A B; C 0], so that B and C are of the size of
    // the rows and columns of A they couple to: the deflation below
    // compares their components with their norms.
    out.poles = canonical_roots(eigenvalues(balance(ss).A), "ss poles");
    const Ss b = balance_system(ss);
    // Zeros by deflating the infinite zeros one at a time (the SISO case of
    // Emami-Naeini & Van Dooren's reduction), then QZ on the Rosenbrock
    // pencil of what remains, which has D != 0:
    //   D == 0: rotate the states (Householder Q, Q^T B = beta e_last) so the
    //   input drives only the last state z2. If y does not see z2 (|C q|
    //   below rounding of |C|), z2 acts as the input of the smaller system
    //   (A11, A12, C1): same zeros, one infinite zero fewer, and the gain
    //   picks up the factor beta. Otherwise the relative degree is reached
    //   and (A11, A12, C1, C2) has D' = C2 != 0.
    // Every decision compares a rotated entry with the norm of its own row,
    // never powers of A, so models whose poles span 1e0 … 1e6 keep their
    // structure (the Markov parameters C A^k B would not resolve it).
    Eigen::MatrixXd a = b.A;
    Eigen::VectorXd bb = b.B;
    Eigen::RowVectorXd cc = b.C;
    double dd = b.D;
    double gain = 1.0;
    bool first = true;
    while (dd == 0.0) {
        const Eigen::Index m = a.rows();
        const double bn = bb.norm(), cn = cc.norm();
        if (m == 0 || bn == 0.0 || cn == 0.0) {  // no path from u to y: H = 0
            out.gain = 0.0;
            return out;
        }
        // Householder reflector H = I - 2 v v^T / v^T v with H bb = beta e_last.
        Eigen::VectorXd v = bb;
        const double sign = bb(m - 1) >= 0.0 ? 1.0 : -1.0;
        v(m - 1) += sign * bn;
        const double beta = -sign * bn;
        const double vv = v.squaredNorm();
        const Eigen::MatrixXd h = Eigen::MatrixXd::Identity(m, m) - (2.0 / vv) * v * v.transpose();
        const Eigen::MatrixXd at = h * a * h;
        const Eigen::RowVectorXd ct = cc * h;
        gain *= beta;
        const double c2 = ct(m - 1);
        // Rounding in c2: the given B is exact, but every later input column
        // is the part of A b orthogonal to b, computed with an absolute
        // error eps |a|; relative to its own norm that is eps |a| / |bb|.
        const double noise = first ? 1.0 : std::max(1.0, a.norm() / bn);
        first = false;
        // Either way z2 becomes the input of the (m-1)-state system; with
        // c2 != 0 it also feeds y directly (D' = c2) and the loop ends.
        if (std::fabs(c2) > kDeflateTol * static_cast<double>(m) * noise * cn) dd = c2;
        a = at.topLeftCorner(m - 1, m - 1);
        bb = at.col(m - 1).head(m - 1);
        cc = ct.head(m - 1);
    }
    out.gain = dd * gain;
    const Eigen::Index m = a.rows();
    if (m == 0) return out;
    if (bb.norm() == 0.0 || cc.norm() == 0.0) {
        // H = D here: the remaining modes are uncontrollable or unobservable
        // and cancel as zeros.
        std::vector<cplx> rest = eigenvalues(a);
        out.zeros = canonical_roots(rest, "ss zeros");
        return out;
    }
    // QZ on [a bb; cc dd] - s [I 0; 0 0]: m finite eigenvalues and one
    // infinite one (dd != 0). bb and cc are scaled to the size of a (moves
    // no zero) so the pencil's backward error is eps |a|. Keep the m smallest.
    // (A zero block, as when one state of a companion-like pair is left,
    // takes the size of bb and cc instead.)
    const double an = std::max(a.norm(), std::sqrt(bb.norm() * cc.norm()));
    const double sb = an / bb.norm(), sc = an / cc.norm();
    Eigen::MatrixXd pencil(m + 1, m + 1), mass = Eigen::MatrixXd::Zero(m + 1, m + 1);
    pencil.topLeftCorner(m, m) = a;
    pencil.topRightCorner(m, 1) = bb * sb;
    pencil.bottomLeftCorner(1, m) = cc * sc;
    pencil(m, m) = dd * sb * sc;
    mass.topLeftCorner(m, m).setIdentity();
    Eigen::GeneralizedEigenSolver<Eigen::MatrixXd> ges(pencil, mass, false);
    if (ges.info() != Eigen::Success) fail("ss: zero computation (QZ) did not converge");
    struct Candidate {
        cplx value;
        double size;
    };
    std::vector<Candidate> cand;
    for (Eigen::Index i = 0; i <= m; ++i) {
        const cplx alpha = ges.alphas()(i);
        const double bt = ges.betas()(i);
        const double size = bt == 0.0 ? std::numeric_limits<double>::infinity() : std::abs(alpha) / std::fabs(bt);
        cand.push_back({bt == 0.0 ? cplx(0.0) : alpha / bt, size});
    }
    std::stable_sort(cand.begin(), cand.end(), [](const Candidate& x, const Candidate& y) { return x.size < y.size; });
    std::vector<cplx> zeros;
    for (Eigen::Index i = 0; i < m; ++i) {
        if (!std::isfinite(cand[static_cast<size_t>(i)].size)) fail("ss: zero computation lost a finite zero");
        zeros.push_back(cand[static_cast<size_t>(i)].value);
    }
    out.zeros = canonical_roots(zeros, "ss zeros");
    return out;
}

Tf ss2tf(const Ss& ss) { return zpk2tf(ss2zpk(ss)); }

// ---- composition -------------------------------------------------------------

Zpk series(const std::vector<Zpk>& models) {
    if (models.empty()) fail("series: needs at least one model");
    Zpk out;
    out.ts = models[0].ts;
    out.gain = 1.0;
    for (const Zpk& m : models) {
        check_ts(out.ts, m.ts, "series");
        out.zeros.insert(out.zeros.end(), m.zeros.begin(), m.zeros.end());
        out.poles.insert(out.poles.end(), m.poles.begin(), m.poles.end());
        out.gain *= m.gain;
    }
    return out;
}

Zpk series(const Zpk& first, const Zpk& second) { return series(std::vector<Zpk>{first, second}); }

Tf series(const Tf& first, const Tf& second) {
    check_ts(first.ts, second.ts, "series");
    Tf out;
    out.ts = first.ts;
    out.num = poly_mul(first.num, second.num);
    out.den = poly_mul(first.den, second.den);
    return out;
}

Ss series(const Ss& first, const Ss& second) {
    check_ss(first);
    check_ss(second);
    check_ts(first.ts, second.ts, "series");
    const Block b = cascade(Block{first.A, first.B, first.C, first.D}, Block{second.A, second.B, second.C, second.D});
    Ss out;
    out.A = b.A;
    out.B = b.B;
    out.C = b.C;
    out.D = b.D;
    out.ts = first.ts;
    return out;
}

int relative_degree(const Zpk& zpk) { return static_cast<int>(zpk.poles.size()) - static_cast<int>(zpk.zeros.size()); }

}  // namespace piezoloop::design
