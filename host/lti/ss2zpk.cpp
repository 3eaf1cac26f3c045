// Ss -> Zpk (and Ss -> Tf through it): poles from eig of A balanced, zeros
// by deflating the infinite zeros and QZ on the remaining pencil; and the
// balancing of a state-space model.
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

// In ss2zpk, a rotated output coefficient below kDeflateTol * n * |C| is
// zero up to the rounding of the rotation (a few n eps |C|): 100 eps.
constexpr double kDeflateTol = 100.0 * std::numeric_limits<double>::epsilon();

}  // namespace

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

}  // namespace piezoloop::design
