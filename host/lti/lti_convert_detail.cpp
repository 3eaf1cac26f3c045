#include "lti/lti_convert_detail.hpp"
#include "lti/text.hpp"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <limits>
#include <stdexcept>
#include <string>

#include <Eigen/Eigenvalues>

namespace piezoloop::design::convert_detail {

void fail(const std::string& what) { throw std::invalid_argument(what); }

bool all_finite(const std::vector<double>& v) {
    return std::all_of(v.begin(), v.end(), [](double x) { return std::isfinite(x); });
}

Eigen::VectorXd balance_in_place(Eigen::MatrixXd& a, bool fixed_last) {
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

}  // namespace piezoloop::design::convert_detail
