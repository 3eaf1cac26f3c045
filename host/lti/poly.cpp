// Polynomials of lti_convert.hpp: roots (scaled, balanced companion matrix
// and guarded Newton polishing), products, conjugate pairing.
#include "lti/lti_convert.hpp"
#include "lti/lti_convert_detail.hpp"
#include "lti/text.hpp"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <limits>
#include <stdexcept>
#include <string>

#include <Eigen/Eigenvalues>

namespace piezoloop::design {
using namespace convert_detail;
namespace {

// Roots closer to an exact conjugate than this (relative to their
// magnitude) are taken as one conjugate pair; a root whose imaginary part is
// below it is taken as real. Far above double rounding (1e-16) and far below
// any distinction a model file could mean.
constexpr double kConjugateTol = 1e-9;

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

}  // namespace piezoloop::design
