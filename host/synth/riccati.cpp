#include "synth/riccati.hpp"

#include <algorithm>
#include <cmath>
#include <cstddef>
#include <limits>
#include <sstream>

#include <Eigen/Eigenvalues>
#include <cstdio>
#include <cstdlib>
#include <vector>

// LAPACK's Fortran interface (liblapack-dev). LOGICAL is a 4-byte integer in
// gfortran; the trailing size_t arguments are the hidden lengths of the
// character arguments that gfortran passes by value.
extern "C" {
using lapack_select2 = int (*)(const double*, const double*);
void dgees_(const char* jobvs, const char* sort, lapack_select2 select, const int* n, double* a, const int* lda,
            int* sdim, double* wr, double* wi, double* vs, const int* ldvs, double* work, const int* lwork,
            int* bwork, int* info, std::size_t jobvs_len, std::size_t sort_len);
}

namespace piezoloop::design {
namespace {

int select_stable(const double* wr, const double* /*wi*/) { return *wr < 0.0 ? 1 : 0; }

struct Schur {
    Eigen::MatrixXd U;                 // orthogonal, leading columns span the stable subspace
    std::vector<double> wr, wi;        // eigenvalues
    int sdim = 0;                      // number of selected (stable) eigenvalues
    int info = 0;
};

Schur ordered_schur(Eigen::MatrixXd h) {
    const int n = static_cast<int>(h.rows());
    Schur s;
    s.U.resize(n, n);
    s.wr.resize(n);
    s.wi.resize(n);
    std::vector<int> bwork(n);
    int lwork = -1;
    double wq = 0.0;
    dgees_("V", "S", select_stable, &n, h.data(), &n, &s.sdim, s.wr.data(), s.wi.data(), s.U.data(), &n, &wq,
           &lwork, bwork.data(), &s.info, 1, 1);
    lwork = std::max(1, static_cast<int>(wq));
    std::vector<double> work(lwork);
    dgees_("V", "S", select_stable, &n, h.data(), &n, &s.sdim, s.wr.data(), s.wi.data(), s.U.data(), &n,
           work.data(), &lwork, bwork.data(), &s.info, 1, 1);
    return s;
}

// Parlett–Reinsch balancing of |h| (no permutation): returns the diagonal
// scaling d (h -> diag(d)^-1 h diag(d)).
Eigen::VectorXd balancing_scales(const Eigen::MatrixXd& h) {
    const Eigen::Index n = h.rows();
    Eigen::MatrixXd a = h.cwiseAbs();
    Eigen::VectorXd d = Eigen::VectorXd::Ones(n);
    bool converged = false;
    for (int sweep = 0; sweep < 100 && !converged; ++sweep) {
        converged = true;
        for (Eigen::Index i = 0; i < n; ++i) {
            double c = a.col(i).sum() - a(i, i), r = a.row(i).sum() - a(i, i);
            if (c == 0.0 || r == 0.0) continue;
            double f = 1.0;
            const double total = c + r;
            while (c < r / 2.0) { c *= 2.0; r /= 2.0; f *= 2.0; }
            while (c >= r * 2.0) { c /= 2.0; r *= 2.0; f /= 2.0; }
            if (c + r < 0.95 * total) {
                converged = false;
                d[i] *= f;
                a.col(i) *= f;
                a.row(i) /= f;
            }
        }
    }
    return d;
}

// One attempt with block scaling c and state scaling d (see the header).
RiccatiResult solve_scaled(const Eigen::MatrixXd& A, const Eigen::MatrixXd& Rs, const Eigen::MatrixXd& Qs, double c,
                           const Eigen::VectorXd& d, const RiccatiOptions& options) {
    const Eigen::Index n = A.rows();
    // x = D x~: A~ = D^-1 A D, R~ = D^-1 R D^-1, Q~ = D Q D, X~ = D X D.
    const Eigen::VectorXd di = d.cwiseInverse();
    Eigen::MatrixXd h(2 * n, 2 * n);
    h.topLeftCorner(n, n) = di.asDiagonal() * A * d.asDiagonal();
    h.topRightCorner(n, n) = -c * (di.asDiagonal() * Rs * di.asDiagonal());
    h.bottomLeftCorner(n, n) = -(d.asDiagonal() * Qs * d.asDiagonal()) / c;
    h.bottomRightCorner(n, n) = -h.topLeftCorner(n, n).transpose();

    RiccatiResult res;
    const double hnorm = h.cwiseAbs().colwise().sum().maxCoeff();
    const Schur s = ordered_schur(h);
    if (s.info != 0) {
        res.failure = RiccatiFailure::kSchur;
        return res;
    }
    // Distance from the axis relative to each eigenvalue's own magnitude
    // (plus a rounding floor relative to |H|): the Hamiltonians of weighted
    // plants have eigenvalues from 1e-4 to 1e4 after scaling, and a small
    // one must not be judged against |H|. An unequal split (sdim != n)
    // means the computed spectrum is not symmetric: eigenvalues too
    // inaccurate to tell the sides apart.
    double gap = std::numeric_limits<double>::infinity();
    for (Eigen::Index i = 0; i < 2 * n; ++i) {
        const double mag = std::hypot(s.wr[i], s.wi[i]) + 1e-5 * std::numeric_limits<double>::epsilon() * hnorm;
        gap = std::min(gap, std::fabs(s.wr[i]) / mag);
    }
    res.axis_gap = gap;
    if (res.axis_gap <= options.axis_tol || s.sdim != n) {
        res.failure = RiccatiFailure::kImaginaryAxis;
        return res;
    }
    const Eigen::MatrixXd u11 = s.U.topLeftCorner(n, n), u21 = s.U.bottomLeftCorner(n, n);
    const Eigen::JacobiSVD<Eigen::MatrixXd> svd(u11);
    const double smax = svd.singularValues()(0), smin = svd.singularValues()(n - 1);
    res.cond_u11 = smin > 0.0 ? smax / smin : std::numeric_limits<double>::infinity();
    if (!(res.cond_u11 < 1e14)) {
        res.failure = RiccatiFailure::kSingularU11;
        return res;
    }
    // X~ U11 = U21  <=>  U11' X~ = U21' (X~ symmetric).
    Eigen::MatrixXd xs = u11.transpose().partialPivLu().solve(u21.transpose());
    xs = 0.5 * (xs + xs.transpose()).eval();
    res.X = c * (di.asDiagonal() * xs * di.asDiagonal());
    res.X = 0.5 * (res.X + res.X.transpose()).eval();

    // Stabilising means A - R X stable; a splitting fooled by rounding
    // shows here.
    const Eigen::VectorXcd cl = (A - Rs * res.X).eigenvalues();
    if (!(cl.real().array() < 0.0).all()) {
        res.failure = RiccatiFailure::kImaginaryAxis;
        return res;
    }
    const Eigen::MatrixXd ax = A.transpose() * res.X;
    const Eigen::MatrixXd resid = ax + ax.transpose() - res.X * Rs * res.X + Qs;
    const Eigen::MatrixXd xrx = res.X * Rs * res.X;
    const double scale = 2.0 * ax.norm() + xrx.norm() + Qs.norm();  // the terms' own sizes
    res.residual = scale > 0.0 ? resid.norm() / scale : 0.0;
    if (!(res.residual <= options.max_residual)) res.failure = RiccatiFailure::kResidual;
    return res;
}

}  // namespace

double pow2_near(double x) { return std::ldexp(1.0, static_cast<int>(std::lround(std::log2(x)))); }

std::string riccati_failure_text(RiccatiFailure f) {
    switch (f) {
        case RiccatiFailure::kNone: return "solved";
        case RiccatiFailure::kImaginaryAxis:
            return "no stabilising solution (the Hamiltonian has eigenvalues on the imaginary axis)";
        case RiccatiFailure::kSingularU11:
            return "no stabilising solution (the stable invariant subspace is not a graph: U11 singular)";
        case RiccatiFailure::kResidual: return "Riccati residual too large";
        case RiccatiFailure::kSchur: return "ordered Schur form failed (LAPACK dgees)";
    }
    return "unknown";
}

RiccatiResult riccati_hamiltonian(const Eigen::MatrixXd& A, const Eigen::MatrixXd& R, const Eigen::MatrixXd& Q,
                                  const RiccatiOptions& options) {
    const Eigen::Index n = A.rows();
    if (A.cols() != n || R.rows() != n || R.cols() != n || Q.rows() != n || Q.cols() != n)
        throw std::invalid_argument("riccati: A, R, Q must be square of the same size");
    if (n == 0) throw std::invalid_argument("riccati: empty A");
    if (!A.allFinite() || !R.allFinite() || !Q.allFinite())
        throw std::invalid_argument("riccati: non-finite entry in A, R or Q");
    const Eigen::MatrixXd Rs = 0.5 * (R + R.transpose()), Qs = 0.5 * (Q + Q.transpose());

    RiccatiResult res;
    // Q = 0 with A stable: X = 0 is the stabilising solution, exactly. (The
    // Schur route would return rounding noise whose relative residual is
    // O(1): the filter equation of every mixed-sensitivity problem is this
    // case, see hinfsyn.cpp's cancel().)
    if (Qs.isZero(0.0)) {
        const Eigen::VectorXcd ev = A.eigenvalues();
        if ((ev.real().array() < 0.0).all()) {
            res.X = Eigen::MatrixXd::Zero(n, n);
            res.cond_u11 = 1.0;
            res.axis_gap = (ev.real().cwiseAbs().array() / ev.cwiseAbs().array()).minCoeff();
            return res;
        }
    }
    // Block scaling c (see the header): X~ = X / c.
    const double nr = Rs.norm(), nq = Qs.norm();
    const double c = (nr > 0.0 && nq > 0.0) ? pow2_near(std::sqrt(nq / nr)) : 1.0;
    // First without the state scaling, then with it (see the header).
    RiccatiResult first = solve_scaled(A, Rs, Qs, c, Eigen::VectorXd::Ones(n), options);
    if (first.ok()) return first;
    Eigen::MatrixXd h(2 * n, 2 * n);
    h << A, -c * Rs, -Qs / c, -A.transpose();
    const Eigen::VectorXd e = balancing_scales(h);
    Eigen::VectorXd d(n);
    for (Eigen::Index i = 0; i < n; ++i) d[i] = pow2_near(std::sqrt(e[i] / e[n + i]));
    if ((d.array() == 1.0).all()) return first;
    RiccatiResult second = solve_scaled(A, Rs, Qs, c, d, options);
    if (second.ok()) return second;
    // Both failed: a residual failure says more than an axis or subspace one.
    if (second.failure == RiccatiFailure::kResidual &&
        (first.failure != RiccatiFailure::kResidual || second.residual < first.residual))
        return second;
    return first;
}

RiccatiResult solve_care(const Eigen::MatrixXd& A, const Eigen::MatrixXd& B, const Eigen::MatrixXd& Q,
                         const Eigen::MatrixXd& Rw, const RiccatiOptions& options) {
    const Eigen::Index n = A.rows(), m = B.cols();
    if (B.rows() != n || Rw.rows() != m || Rw.cols() != m)
        throw std::invalid_argument("care: B must have the rows of A and Rw the columns of B");
    const Eigen::LLT<Eigen::MatrixXd> llt(0.5 * (Rw + Rw.transpose()));
    if (llt.info() != Eigen::Success) throw std::invalid_argument("care: Rw must be positive definite");
    const Eigen::MatrixXd R = B * llt.solve(B.transpose());
    RiccatiResult r = riccati_hamiltonian(A, R, Q, options);
    if (!r.ok()) {
        std::ostringstream msg;
        msg << riccati_failure_text(r.failure);
        if (r.failure == RiccatiFailure::kResidual) msg << " (X: " << r.residual << ")";
        throw RiccatiError(r.failure, msg.str());
    }
    return r;
}

}  // namespace piezoloop::design
