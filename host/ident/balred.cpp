#include "ident/balred.hpp"

#include <cmath>
#include <limits>
#include <sstream>
#include <stdexcept>

#include <Eigen/Eigenvalues>

#include "lti/lti_convert.hpp"

namespace piezoloop::design {
namespace {

using CMat = Eigen::MatrixXcd;
using CVec = Eigen::VectorXcd;

void check_model(const Ss& sys) {
    const auto n = sys.A.rows();
    if (n < 1) throw std::invalid_argument("A: the model has no states");
    if (n > 200) throw std::invalid_argument("A: at most 200 states (dense O(n^3) solvers)");
    if (sys.A.cols() != n) throw std::invalid_argument("A: must be square");
    if (sys.B.size() != n) throw std::invalid_argument("B: must have as many rows as A");
    if (sys.C.size() != n) throw std::invalid_argument("C: must have as many columns as A");
    if (!sys.A.allFinite()) throw std::invalid_argument("A: contains NaN/Inf");
    if (!sys.B.allFinite()) throw std::invalid_argument("B: contains NaN/Inf");
    if (!sys.C.allFinite()) throw std::invalid_argument("C: contains NaN/Inf");
    if (!std::isfinite(sys.D)) throw std::invalid_argument("D: is NaN/Inf");
    if (sys.ts < 0.0 || !std::isfinite(sys.ts)) throw std::invalid_argument("ts: must be finite and >= 0");
    Eigen::EigenSolver<Eigen::MatrixXd> es(sys.A, false);
    for (int i = 0; i < es.eigenvalues().size(); ++i) {
        const cplx p = es.eigenvalues()(i);
        const bool stable = is_discrete(sys.ts) ? std::abs(p) < 1.0 : p.real() < 0.0;
        if (!stable) {
            std::ostringstream m;
            m << "model: not stable (pole " << p.real() << (p.imag() < 0 ? " - " : " + ") << std::fabs(p.imag())
              << "j" << (is_discrete(sys.ts) ? ", |z| >= 1" : ", Re >= 0")
              << "); balanced truncation needs a stable model (split off the unstable part first)";
            throw std::invalid_argument(m.str());
        }
    }
}

// Real symmetric X from the triangular solution Y in Schur coordinates.
Eigen::MatrixXd back_to_real(const CMat& u, const CMat& y) {
    const Eigen::MatrixXd x = (u * y * u.adjoint()).real();
    return 0.5 * (x + x.transpose());
}

// L with X = L L' (X symmetric positive semidefinite up to rounding).
Eigen::MatrixXd psd_factor(const Eigen::MatrixXd& x) {
    Eigen::SelfAdjointEigenSolver<Eigen::MatrixXd> es(x);
    const Eigen::VectorXd l = es.eigenvalues().cwiseMax(0.0).cwiseSqrt();
    return es.eigenvectors() * l.asDiagonal();
}

struct Factors {
    Eigen::MatrixXd a, b, c;  // balanced-scaled model
    Eigen::MatrixXd lp, lq;
    Eigen::JacobiSVD<Eigen::MatrixXd> svd;
};

Factors factors(const Ss& sys) {
    check_model(sys);
    const Ss bal = balance(sys);
    Factors f;
    f.a = bal.A;
    f.b = bal.B;
    f.c = bal.C;
    const Eigen::MatrixXd bb = f.b * f.b.transpose();
    const Eigen::MatrixXd cc = f.c.transpose() * f.c;
    Eigen::MatrixXd p, q;
    if (is_discrete(sys.ts)) {
        p = solve_lyapunov_discrete(f.a, bb);
        q = solve_lyapunov_discrete(f.a.transpose(), cc);
    } else {
        p = solve_lyapunov_continuous(f.a, bb);
        q = solve_lyapunov_continuous(f.a.transpose(), cc);
    }
    f.lp = psd_factor(p);
    f.lq = psd_factor(q);
    f.svd.compute(f.lq.transpose() * f.lp, Eigen::ComputeFullU | Eigen::ComputeFullV);
    return f;
}

}  // namespace

Eigen::MatrixXd solve_lyapunov_continuous(const Eigen::MatrixXd& A, const Eigen::MatrixXd& Q) {
    const int n = static_cast<int>(A.rows());
    Eigen::ComplexSchur<Eigen::MatrixXd> schur(A);
    const CMat& t = schur.matrixT();
    const CMat& u = schur.matrixU();
    const CMat f = u.adjoint() * Q.cast<cplx>() * u;
    CMat y = CMat::Zero(n, n);
    // T Y + Y T^H = -F, column j from the last: (T + conj(t_jj) I) y_j =
    // -f_j - sum_{l > j} y_l conj(t_jl).
    for (int j = n - 1; j >= 0; --j) {
        CVec rhs = -f.col(j);
        for (int l = j + 1; l < n; ++l) rhs -= y.col(l) * std::conj(t(j, l));
        CMat m = t;
        m.diagonal().array() += std::conj(t(j, j));
        y.col(j) = m.triangularView<Eigen::Upper>().solve(rhs);
    }
    return back_to_real(u, y);
}

Eigen::MatrixXd solve_lyapunov_discrete(const Eigen::MatrixXd& A, const Eigen::MatrixXd& Q) {
    const int n = static_cast<int>(A.rows());
    Eigen::ComplexSchur<Eigen::MatrixXd> schur(A);
    const CMat& t = schur.matrixT();
    const CMat& u = schur.matrixU();
    const CMat f = u.adjoint() * Q.cast<cplx>() * u;
    CMat y = CMat::Zero(n, n);
    // T Y T^H - Y = -F, column j from the last:
    // (conj(t_jj) T - I) y_j = -f_j - T sum_{l > j} y_l conj(t_jl).
    for (int j = n - 1; j >= 0; --j) {
        CVec w = CVec::Zero(n);
        for (int l = j + 1; l < n; ++l) w += y.col(l) * std::conj(t(j, l));
        const CVec rhs = -f.col(j) - t * w;
        CMat m = std::conj(t(j, j)) * t;
        m.diagonal().array() -= 1.0;
        y.col(j) = m.triangularView<Eigen::Upper>().solve(rhs);
    }
    return back_to_real(u, y);
}

std::vector<double> hankel_singular_values(const Ss& sys) {
    const Factors f = factors(sys);
    const Eigen::VectorXd s = f.svd.singularValues();
    return std::vector<double>(s.data(), s.data() + s.size());
}

BalancedTruncation balanced_truncation(const Ss& sys, int order) {
    const Factors f = factors(sys);
    const int n = static_cast<int>(sys.A.rows());
    if (order < 1 || order > n)
        throw std::invalid_argument("order: must be in [1, " + std::to_string(n) + "] (the model's state count)");
    const Eigen::VectorXd s = f.svd.singularValues();
    BalancedTruncation out;
    out.hsv.assign(s.data(), s.data() + s.size());
    out.order = order;
    int minimal = 0;
    for (int i = 0; i < n; ++i)
        if (s(i) > 1e3 * std::numeric_limits<double>::epsilon() * n * s(0)) ++minimal;
    if (order > minimal) {
        std::ostringstream m;
        m << "order: Hankel singular value " << order << " is " << s(order - 1)
          << ", at rounding level of the largest (" << s(0) << "): only " << minimal
          << " states are both controllable and observable; choose order <= " << minimal;
        throw std::invalid_argument(m.str());
    }
    for (int i = order; i < n; ++i) out.error_bound += 2.0 * s(i);
    const Eigen::VectorXd s1 = s.head(order).cwiseSqrt().cwiseInverse();
    const Eigen::MatrixXd tl = s1.asDiagonal() * f.svd.matrixU().leftCols(order).transpose() * f.lq.transpose();
    const Eigen::MatrixXd tr = f.lp * f.svd.matrixV().leftCols(order) * s1.asDiagonal();
    out.reduced.A = tl * f.a * tr;
    out.reduced.B = tl * f.b;
    out.reduced.C = f.c * tr;
    out.reduced.D = sys.D;
    out.reduced.ts = sys.ts;
    return out;
}

}  // namespace piezoloop::design
