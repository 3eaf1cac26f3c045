#include "synth/state_space.hpp"

#include <cmath>
#include <stdexcept>

#include <Eigen/Eigenvalues>

namespace piezoloop::design {

void check_state_space(const StateSpace& g, const std::string& what) {
    const Eigen::Index n = g.A.rows();
    if (g.A.cols() != n || g.B.rows() != n || g.C.cols() != n || g.D.rows() != g.C.rows() ||
        g.D.cols() != g.B.cols())
        throw std::invalid_argument(what + ": sizes of A, B, C, D disagree");
    if (!g.A.allFinite() || !g.B.allFinite() || !g.C.allFinite() || !g.D.allFinite())
        throw std::invalid_argument(what + ": non-finite entry");
}

StateSpace from_siso(const Ss& g) {
    if (is_discrete(g.ts)) throw std::invalid_argument("synthesis: the model must be continuous (no ts)");
    StateSpace s;
    s.A = g.A;
    s.B = g.B;
    s.C = g.C;
    s.D = Eigen::MatrixXd::Constant(1, 1, g.D);
    return s;
}

Ss to_siso(const StateSpace& g, Eigen::Index output, Eigen::Index input) {
    Ss s;
    s.A = g.A;
    s.B = g.B.col(input);
    s.C = g.C.row(output);
    s.D = g.D(output, input);
    return s;
}

Eigen::MatrixXcd evaluate(const StateSpace& g, std::complex<double> s) {
    const Eigen::Index n = g.states();
    Eigen::MatrixXcd d = g.D.cast<std::complex<double>>();
    if (n == 0) return d;
    const Eigen::MatrixXcd m = s * Eigen::MatrixXcd::Identity(n, n) - g.A.cast<std::complex<double>>();
    return g.C.cast<std::complex<double>>() * m.partialPivLu().solve(g.B.cast<std::complex<double>>()) + d;
}

StateSpace lft_lower(const StateSpace& p, const StateSpace& k) {
    // P: inputs [w; u], outputs [z; y]; K: y -> u.
    const Eigen::Index nu = k.outputs(), ny = k.inputs();
    const Eigen::Index nw = p.inputs() - nu, nz = p.outputs() - ny;
    if (nw < 0 || nz < 0) throw std::invalid_argument("lft: controller larger than the plant's partition");
    const Eigen::Index np = p.states(), nk = k.states();
    const Eigen::MatrixXd B1 = p.B.leftCols(nw), B2 = p.B.rightCols(nu);
    const Eigen::MatrixXd C1 = p.C.topRows(nz), C2 = p.C.bottomRows(ny);
    const Eigen::MatrixXd D11 = p.D.topLeftCorner(nz, nw), D12 = p.D.topRightCorner(nz, nu);
    const Eigen::MatrixXd D21 = p.D.bottomLeftCorner(ny, nw), D22 = p.D.bottomRightCorner(ny, nu);
    // y = C2 x + D21 w + D22 u, u = Ck xk + Dk y  =>  (I - D22 Dk) y = C2 x + D21 w + D22 Ck xk.
    const Eigen::MatrixXd m = Eigen::MatrixXd::Identity(ny, ny) - D22 * k.D;
    Eigen::FullPivLU<Eigen::MatrixXd> lu(m);
    if (!lu.isInvertible()) throw std::domain_error("lft: I - D22 DK is singular (the loop is not well posed)");
    const Eigen::MatrixXd mi = lu.inverse();
    // y = Y_x x + Y_k xk + Y_w w
    const Eigen::MatrixXd Yx = mi * C2, Yk = mi * D22 * k.C, Yw = mi * D21;
    // u = Ck xk + Dk y
    const Eigen::MatrixXd Ux = k.D * Yx, Uk = k.C + k.D * Yk, Uw = k.D * Yw;
    StateSpace c;
    c.A.resize(np + nk, np + nk);
    c.A.topLeftCorner(np, np) = p.A + B2 * Ux;
    c.A.topRightCorner(np, nk) = B2 * Uk;
    c.A.bottomLeftCorner(nk, np) = k.B * Yx;
    c.A.bottomRightCorner(nk, nk) = k.A + k.B * Yk;
    c.B.resize(np + nk, nw);
    c.B.topRows(np) = B1 + B2 * Uw;
    c.B.bottomRows(nk) = k.B * Yw;
    c.C.resize(nz, np + nk);
    c.C.leftCols(np) = C1 + D12 * Ux;
    c.C.rightCols(nk) = D12 * Uk;
    c.D = D11 + D12 * Uw;
    return c;
}

StateSpace balance_states(const StateSpace& g) {
    // Parlett–Reinsch on the states of [A B; C 0]: the scaling d_i of state i
    // multiplies column i and divides row i of A, divides row i of B and
    // multiplies column i of C. Powers of two keep it exact.
    StateSpace s = g;
    const Eigen::Index n = s.states();
    constexpr double kRadix = 2.0;
    bool converged = false;
    for (int sweep = 0; sweep < 100 && !converged; ++sweep) {
        converged = true;
        for (Eigen::Index i = 0; i < n; ++i) {
            double c = 0.0, r = 0.0;  // off-diagonal column / row norms (1-norm, as gebal)
            for (Eigen::Index j = 0; j < n; ++j)
                if (j != i) {
                    c += std::fabs(s.A(j, i));
                    r += std::fabs(s.A(i, j));
                }
            c += s.C.col(i).cwiseAbs().sum();
            r += s.B.row(i).cwiseAbs().sum();
            if (c == 0.0 || r == 0.0) continue;
            double f = 1.0;
            const double total = c + r;
            while (c < r / kRadix) { c *= kRadix; r /= kRadix; f *= kRadix; }
            while (c >= r * kRadix) { c /= kRadix; r *= kRadix; f /= kRadix; }
            if (c + r < 0.95 * total) {
                converged = false;
                s.A.col(i) *= f;
                s.A.row(i) /= f;
                s.B.row(i) /= f;
                s.C.col(i) *= f;
            }
        }
    }
    return s;
}

bool is_stable(const StateSpace& g) {
    if (g.states() == 0) return true;
    const Eigen::VectorXcd ev = g.A.eigenvalues();
    for (Eigen::Index i = 0; i < ev.size(); ++i)
        if (!(ev[i].real() < 0.0)) return false;
    return true;
}

}  // namespace piezoloop::design
