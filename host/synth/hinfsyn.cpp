#include "synth/hinfsyn.hpp"

#include <algorithm>
#include <cmath>
#include <complex>
#include <limits>

#include <Eigen/Eigenvalues>

#include "synth/mimo_hinf.hpp"
#include "format/number.hpp"

namespace piezoloop::design {
namespace {

using Eigen::Index;
using Eigen::MatrixXd;

double sigma_max(const MatrixXd& m) {
    if (m.size() == 0) return 0.0;
    return Eigen::JacobiSVD<MatrixXd>(m).singularValues()(0);
}

// Inverse of a possibly empty square matrix (Eigen's inverse() of 0x0 is not defined).
MatrixXd inv(const MatrixXd& m) {
    if (m.rows() == 0) return m;
    return m.partialPivLu().inverse();
}

// The plant in the normal form of hinfsyn.hpp and what undoes it.
struct Normal {
    StateSpace p;      // D12 = [0; I], D21 = [0 I], D22 = 0
    MatrixXd d22;      // the normalised D22 that loop shifting removed
    MatrixXd tu;       // u = tu u~  (V Σ^-1)
    MatrixXd ty;       // y~ = ty y  (Σ~^-1 U~')
    double w0 = 1.0;   // s = w0 s~
    Index nw = 0, nu = 0, nz = 0, ny = 0;
    MatrixXd A, B1, B2, C1, C2, D11;  // blocks of p
};

Normal normalise(const GeneralisedPlant& plant) {
    Normal n;
    n.nw = plant.n_w;
    n.nu = plant.n_u;
    n.nz = plant.n_z;
    n.ny = plant.n_y;
    StateSpace s = balance_states(plant.sys);
    const Eigen::VectorXcd ev = s.A.eigenvalues();
    double wmin = std::numeric_limits<double>::infinity(), wmax = 0.0;
    for (Index i = 0; i < ev.size(); ++i) {
        const double m = std::abs(ev[i]);
        if (m > 0.0) {
            wmin = std::min(wmin, m);
            wmax = std::max(wmax, m);
        }
    }
    n.w0 = wmax > 0.0 ? pow2_near(std::sqrt(wmin * wmax)) : 1.0;
    s.A /= n.w0;
    s.B /= n.w0;

    const MatrixXd B1 = s.B.leftCols(n.nw), B2 = s.B.rightCols(n.nu);
    const MatrixXd C1 = s.C.topRows(n.nz), C2 = s.C.bottomRows(n.ny);
    const MatrixXd D11 = s.D.topLeftCorner(n.nz, n.nw), D12 = s.D.topRightCorner(n.nz, n.nu);
    const MatrixXd D21 = s.D.bottomLeftCorner(n.ny, n.nw), D22 = s.D.bottomRightCorner(n.ny, n.nu);

    // D12 = U [0; Σ] V': the rank test is relative to the z rows' size, so
    // a small but deliberate control weight (1e-6) is not mistaken for none.
    const double zscale = std::max({sigma_max(C1), sigma_max(D11), sigma_max(D12), 1e-300});
    Eigen::JacobiSVD<MatrixXd> s12(D12, Eigen::ComputeFullU | Eigen::ComputeFullV);
    if (n.nz < n.nu || s12.singularValues()(n.nu - 1) <= 1e-10 * zscale)
        throw SynthesisError("D12 not of full column rank (the controls u must all reach the outputs z directly; "
                             "in mixed sensitivity: give a W2 with a non-zero high-frequency gain)");
    MatrixXd U(n.nz, n.nz);
    U << s12.matrixU().rightCols(n.nz - n.nu), s12.matrixU().leftCols(n.nu);
    n.tu = s12.matrixV() * s12.singularValues().cwiseInverse().asDiagonal();

    const double yscale = std::max({sigma_max(B1.transpose()), sigma_max(D11), sigma_max(D21), 1e-300});
    Eigen::JacobiSVD<MatrixXd> s21(D21, Eigen::ComputeFullU | Eigen::ComputeFullV);
    if (n.nw < n.ny || s21.singularValues()(n.ny - 1) <= 1e-10 * yscale)
        throw SynthesisError("D21 not of full row rank (every measurement y must see the inputs w directly: "
                             "sensor noise on each)");
    MatrixXd V(n.nw, n.nw);
    V << s21.matrixV().rightCols(n.nw - n.ny), s21.matrixV().leftCols(n.ny);
    n.ty = s21.singularValues().cwiseInverse().asDiagonal() * s21.matrixU().transpose();

    n.A = s.A;
    n.B1 = B1 * V;
    n.B2 = B2 * n.tu;
    n.C1 = U.transpose() * C1;
    n.C2 = n.ty * C2;
    n.D11 = U.transpose() * D11 * V;
    n.d22 = n.ty * D22 * n.tu;
    n.p.A = n.A;
    n.p.B.resize(n.A.rows(), n.nw + n.nu);
    n.p.B << n.B1, n.B2;
    n.p.C.resize(n.nz + n.ny, n.A.rows());
    n.p.C << n.C1, n.C2;
    n.p.D = MatrixXd::Zero(n.nz + n.ny, n.nw + n.nu);
    n.p.D.topLeftCorner(n.nz, n.nw) = n.D11;
    n.p.D.block(n.nz - n.nu, n.nw, n.nu, n.nu).setIdentity();
    n.p.D.block(n.nz, n.nw - n.ny, n.ny, n.ny).setIdentity();
    return n;
}

// Hautus tests at the modes with Re λ >= 0 (tolerance relative to |A|).
void check_stabilisable(const MatrixXd& A, const MatrixXd& B, double w0, const char* what) {
    const Index n = A.rows();
    const double an = std::max(A.cwiseAbs().colwise().sum().maxCoeff(), 1e-300);
    const double scale = std::max(an, sigma_max(B));
    const Eigen::VectorXcd ev = A.eigenvalues();
    for (Index i = 0; i < ev.size(); ++i) {
        if (ev[i].real() < -1e-9 * an) continue;
        Eigen::MatrixXcd m(n, n + B.cols());
        m << A.cast<std::complex<double>>() - ev[i] * Eigen::MatrixXcd::Identity(n, n), B.cast<std::complex<double>>();
        const Eigen::VectorXd sv = Eigen::JacobiSVD<Eigen::MatrixXcd>(m).singularValues();
        if (sv(n - 1) <= 1e-9 * scale)
            throw SynthesisError(std::string(what) + " (mode at " + format::complex_significant(ev[i] * w0, 4) + " rad/s)");
    }
}

// The γ = ∞ Hamiltonians: imaginary eigenvalues there are the ω where
// [A - jωI B2; C1 D12] (resp. [A - jωI B1; C2 D21]) loses rank.
void check_axis_rank(const Normal& n, const RiccatiOptions& ro) {
    const MatrixXd D12 = n.p.D.topRightCorner(n.nz, n.nu), D21 = n.p.D.bottomLeftCorner(n.ny, n.nw);
    const Index k = n.A.rows();
    auto fail_at = [&](const MatrixXd& a, const MatrixXd& r, const MatrixXd& q, const std::string& what) {
        const RiccatiResult res = riccati_hamiltonian(a, r, q, ro);
        if (res.failure != RiccatiFailure::kImaginaryAxis) return;
        MatrixXd h(2 * k, 2 * k);
        h << a, -r, -q, -a.transpose();
        const Eigen::VectorXcd ev = h.eigenvalues();
        Index best = 0;
        for (Index i = 0; i < ev.size(); ++i)
            if (std::fabs(ev[i].real()) < std::fabs(ev[best].real())) best = i;
        throw SynthesisError(what + " loses rank at ω = " + format::significant(std::fabs(ev[best].imag()) * n.w0, 4) +
                             " rad/s (a zero of the plant on the imaginary axis)");
    };
    const MatrixXd Ix = MatrixXd::Identity(n.nz, n.nz) - D12 * D12.transpose();
    fail_at(n.A - n.B2 * D12.transpose() * n.C1, n.B2 * n.B2.transpose(), n.C1.transpose() * Ix * n.C1,
            "[A - jωI B2; C1 D12]");
    const MatrixXd Iy = MatrixXd::Identity(n.nw, n.nw) - D21.transpose() * D21;
    fail_at((n.A - n.B1 * D21.transpose() * n.C2).transpose(), n.C2.transpose() * n.C2,
            n.B1 * Iy * n.B1.transpose(), "[A - jωI B1; C2 D21]");
}

double d11_bound(const Normal& n) {
    return std::max(sigma_max(n.D11.topRows(n.nz - n.nu)), sigma_max(n.D11.leftCols(n.nw - n.ny)));
}

// a - b for symmetric a, b, with the eigenvalues at rounding level of the
// terms set to exactly zero. I - D.1' R~^-1 D.1 vanishes in exact
// arithmetic when D21 is square (w = y: the filtering problem is trivial and
// Y∞ = 0); its rounding, ~1e-17, would otherwise be the whole right-hand
// side of the Y∞ equation and its residual meaningless. With D21 = I square,
// R~^-1 D.1 = [0; I] exactly (R~ [0; I] = D.1), so the difference is zero
// and `exact_zero` says so; the same for X∞ with D12 square.
MatrixXd cancel(const MatrixXd& a, const MatrixXd& b, bool exact_zero) {
    if (exact_zero) return MatrixXd::Zero(a.rows(), a.cols());
    const MatrixXd d = 0.5 * ((a - b) + (a - b).transpose());
    if (d.rows() == 0) return d;
    const Eigen::SelfAdjointEigenSolver<MatrixXd> es(d);
    const double floor = 1e-13 * std::max({1.0, a.norm(), b.norm()});
    Eigen::VectorXd l = es.eigenvalues();
    for (Index i = 0; i < l.size(); ++i)
        if (std::fabs(l[i]) <= floor) l[i] = 0.0;
    return es.eigenvectors() * l.asDiagonal() * es.eigenvectors().transpose();
}

struct GammaTest {
    bool ok = false;
    std::string why;
    RiccatiResult x, y;
    double rho = 0.0;
    MatrixXd F, L;
};

// The existence tests of ZDG chapter 17 at one γ.
GammaTest test_gamma(const Normal& n, double gamma, const RiccatiOptions& ro) {
    GammaTest t;
    const Index m1 = n.nw, m2 = n.nu, p1 = n.nz, p2 = n.ny, k = n.A.rows();
    if (!(gamma > d11_bound(n))) {
        t.why = "γ <= max(σ̄[D1111 D1112], σ̄[D1111' D1121'])";
        return t;
    }
    const double g2 = gamma * gamma;
    MatrixXd D1(p1, m1 + m2), Dc(p1 + p2, m1), B(k, m1 + m2), C(p1 + p2, k);
    D1 << n.D11, n.p.D.topRightCorner(p1, m2);
    Dc << n.D11, n.p.D.bottomLeftCorner(p2, m1);
    B << n.B1, n.B2;
    C << n.C1, n.C2;
    MatrixXd R = D1.transpose() * D1;
    R.topLeftCorner(m1, m1) -= g2 * MatrixXd::Identity(m1, m1);
    MatrixXd Rt = Dc * Dc.transpose();
    Rt.topLeftCorner(p1, p1) -= g2 * MatrixXd::Identity(p1, p1);
    const MatrixXd Ri = inv(R), Rti = inv(Rt);

    t.x = riccati_hamiltonian(n.A - B * Ri * D1.transpose() * n.C1, B * Ri * B.transpose(),
                              n.C1.transpose() * cancel(MatrixXd::Identity(p1, p1), D1 * Ri * D1.transpose(), p1 == m2) * n.C1,
                              ro);
    if (!t.x.ok()) {
        t.why = "X∞: " + riccati_failure_text(t.x.failure) +
                (t.x.failure == RiccatiFailure::kResidual ? " (X: " + format::significant(t.x.residual, 4) + ")" : "");
        return t;
    }
    t.y = riccati_hamiltonian((n.A - n.B1 * Dc.transpose() * Rti * C).transpose(), C.transpose() * Rti * C,
                              n.B1 * cancel(MatrixXd::Identity(m1, m1), Dc.transpose() * Rti * Dc, m1 == p2) * n.B1.transpose(),
                              ro);
    if (!t.y.ok()) {
        t.why = "Y∞: " + riccati_failure_text(t.y.failure) +
                (t.y.failure == RiccatiFailure::kResidual ? " (Y: " + format::significant(t.y.residual, 4) + ")" : "");
        return t;
    }
    // Semidefiniteness to rounding level of the solution's size.
    const double xmin = Eigen::SelfAdjointEigenSolver<MatrixXd>(t.x.X).eigenvalues().minCoeff();
    if (xmin < -1e-8 * std::max(t.x.X.norm(), 1e-300)) {
        t.why = "X∞ not positive semidefinite (λmin " + format::significant(xmin, 4) + ")";
        return t;
    }
    const double ymin = Eigen::SelfAdjointEigenSolver<MatrixXd>(t.y.X).eigenvalues().minCoeff();
    if (ymin < -1e-8 * std::max(t.y.X.norm(), 1e-300)) {
        t.why = "Y∞ not positive semidefinite (λmin " + format::significant(ymin, 4) + ")";
        return t;
    }
    const Eigen::VectorXcd exy = (t.x.X * t.y.X).eigenvalues();
    t.rho = exy.cwiseAbs().maxCoeff();
    if (!(t.rho < g2)) {
        t.why = "ρ(X∞Y∞) = " + format::significant(t.rho, 4) + " >= γ² = " + format::significant(g2, 4);
        return t;
    }
    t.F = -Ri * (D1.transpose() * n.C1 + B.transpose() * t.x.X);
    t.L = -(n.B1 * Dc.transpose() + t.y.X * C.transpose()) * Rti;
    t.ok = true;
    return t;
}

// The central controller of ZDG chapter 17 (general D11), in the normal form.
StateSpace central_controller(const Normal& n, const GammaTest& t, double gamma) {
    const Index m1 = n.nw, m2 = n.nu, p1 = n.nz, p2 = n.ny, k = n.A.rows();
    const double g2 = gamma * gamma;
    const MatrixXd D1111 = n.D11.topLeftCorner(p1 - m2, m1 - p2), D1112 = n.D11.topRightCorner(p1 - m2, p2);
    const MatrixXd D1121 = n.D11.bottomLeftCorner(m2, m1 - p2), D1122 = n.D11.bottomRightCorner(m2, p2);
    const MatrixXd G1 = inv(g2 * MatrixXd::Identity(p1 - m2, p1 - m2) - D1111 * D1111.transpose());
    const MatrixXd G2 = inv(g2 * MatrixXd::Identity(m1 - p2, m1 - p2) - D1111.transpose() * D1111);
    MatrixXd Dh11 = -D1122;
    if (p1 > m2 && m1 > p2) Dh11 -= D1121 * D1111.transpose() * G1 * D1112;
    MatrixXd M12 = MatrixXd::Identity(m2, m2), M21 = MatrixXd::Identity(p2, p2);
    if (m1 > p2) M12 -= D1121 * G2 * D1121.transpose();
    if (p1 > m2) M21 -= D1112.transpose() * G1 * D1112;
    const Eigen::LLT<MatrixXd> l12(M12), l21(M21);
    if (l12.info() != Eigen::Success || l21.info() != Eigen::Success)
        throw SynthesisError("controller: I - D1121 (γ² - D1111'D1111)^-1 D1121' not positive definite");
    const MatrixXd Dh12 = l12.matrixL(), Dh21 = l21.matrixU();  // Dh12 Dh12' = M12, Dh21' Dh21 = M21
    const MatrixXd F12 = t.F.middleRows(m1 - p2, p2), F2 = t.F.bottomRows(m2);
    const MatrixXd L12 = t.L.middleCols(p1 - m2, m2), L2 = t.L.rightCols(p2);
    const MatrixXd Zm = MatrixXd::Identity(k, k) - t.y.X * t.x.X / g2;
    Eigen::FullPivLU<MatrixXd> zlu(Zm);
    if (!zlu.isInvertible()) throw SynthesisError("controller: I - γ^-2 Y∞X∞ is singular (γ at the optimum)");
    const MatrixXd Z = zlu.inverse();
    MatrixXd B(k, m1 + m2);
    B << n.B1, n.B2;
    const MatrixXd Bh2 = Z * (n.B2 + L12) * Dh12;
    const MatrixXd Ch2 = -Dh21 * (n.C2 + F12);
    const MatrixXd Dh12i = Dh12.inverse(), Dh21i = Dh21.inverse();
    const MatrixXd Bh1 = -Z * L2 + Bh2 * Dh12i * Dh11;
    const MatrixXd Ch1 = F2 + Dh11 * Dh21i * Ch2;
    StateSpace c;
    c.A = n.A + B * t.F + Bh1 * Dh21i * Ch2;
    c.B = Bh1;
    c.C = Ch1;
    c.D = Dh11;
    return c;
}

// Normal-form controller -> controller of the plant as given.
StateSpace restore(const Normal& n, const StateSpace& k0) {
    // Loop shifting: K~ = K0 (I + D22~ K0)^-1.
    const Index nu = n.nu, ny = n.ny;
    const MatrixXd M = inv(MatrixXd::Identity(nu, nu) + k0.D * n.d22);
    StateSpace k;
    k.A = k0.A - k0.B * n.d22 * M * k0.C;
    k.B = k0.B * (MatrixXd::Identity(ny, ny) - n.d22 * M * k0.D);
    k.C = M * k0.C;
    k.D = M * k0.D;
    // u = tu u~, y~ = ty y; then s~ = s / w0.
    k.B = k.B * n.ty * n.w0;
    k.A = k.A * n.w0;
    k.C = n.tu * k.C;
    k.D = n.tu * k.D * n.ty;
    return k;
}

}  // namespace

void check_plant(const GeneralisedPlant& p, const std::string& what) {
    check_state_space(p.sys, what);
    if (p.n_w < 1 || p.n_u < 1 || p.n_z < 1 || p.n_y < 1)
        throw std::invalid_argument(what + ": every partition (w, u, z, y) needs at least one signal");
    if (p.sys.inputs() != p.n_w + p.n_u)
        throw std::invalid_argument(what + ": B and D have " + std::to_string(p.sys.inputs()) +
                                    " columns, the partition says w + u = " + std::to_string(p.n_w + p.n_u));
    if (p.sys.outputs() != p.n_z + p.n_y)
        throw std::invalid_argument(what + ": C and D have " + std::to_string(p.sys.outputs()) +
                                    " rows, the partition says z + y = " + std::to_string(p.n_z + p.n_y));
    if (p.sys.states() < 1) throw std::invalid_argument(what + ": A: at least one state");
}

HinfSynthesis hinfsyn(const GeneralisedPlant& plant, const HinfOptions& o) {
    check_plant(plant);
    if (!(o.rel_tol >= 1e-12 && o.rel_tol <= 0.1)) throw std::invalid_argument("gamma_tol: must be in [1e-12, 0.1]");
    if (!(o.backoff >= 0.0 && o.backoff <= 1.0)) throw std::invalid_argument("backoff: must be in [0, 1]");
    if (!(o.gamma_min >= 0.0) || !(o.gamma_max >= 0.0) || !std::isfinite(o.gamma_max))
        throw std::invalid_argument("gamma_min, gamma_max: must be finite and >= 0");

    const Normal n = normalise(plant);
    check_stabilisable(n.A, n.B2, n.w0, "(A, B2) not stabilisable: an unstable mode the controls cannot reach");
    check_stabilisable(n.A.transpose(), n.C2.transpose(), n.w0,
                       "(C2, A) not detectable: an unstable mode the measurements do not see");
    check_axis_rank(n, o.riccati);

    HinfSynthesis r;
    r.w0_rad_s = n.w0;
    const double bound = d11_bound(n);
    double lo = std::max(o.gamma_min, bound);
    GammaTest last;
    auto feasible = [&](double g) {
        ++r.iterations;
        try {
            last = test_gamma(n, g, o.riccati);
        } catch (const std::invalid_argument& e) {
            // The plant was checked; a non-finite Hamiltonian here is γ
            // beyond what double precision holds (1 / γ² overflowing).
            last = GammaTest{};
            last.why = e.what();
        }
        return last.ok;
    };
    double hi = 0.0;
    if (o.gamma_max > 0.0) {
        if (o.gamma_max <= lo || !feasible(o.gamma_max))
            throw SynthesisError("no γ in the search interval [" + format::significant(lo, 4) + ", " + format::significant(o.gamma_max, 4) + "]: at γ = " +
                                 format::significant(o.gamma_max, 4) + ", " + (last.why.empty() ? "γ <= lower end" : last.why));
        hi = o.gamma_max;
    } else {
        double g = std::max(1.0, 2.0 * lo);
        while (!feasible(g)) {
            if (g >= 1e15)
                throw SynthesisError("no γ in the search interval [" + format::significant(lo, 4) + ", 1e+15]: at γ = 1e+15, " +
                                     last.why);
            g = std::min(g * 10.0, 1e15);
        }
        hi = g;
    }
    // A feasible γ_min ends the search there; a zero lower end is found by
    // decades, down to 1e-12 of the first feasible γ. A problem still
    // feasible there has the optimum γ = 0 as far as double precision
    // tells (the closed loop can be made all but identically zero: the
    // achieved norm is then rounding, ~1e-16 of the plant's scale): the
    // controller is the γ-suboptimal one at that floor, gamma_lower 0.
    if (lo > 0.0 && feasible(lo)) {
        hi = lo;
    } else if (lo < hi * 1e-15 || lo == 0.0) {
        bool feasible_to_floor = true;
        double g = hi / 10.0;
        for (int decade = 1; decade <= 12; ++decade, g /= 10.0) {
            if (!feasible(g)) {
                lo = std::max(lo, g);
                feasible_to_floor = false;
                break;
            }
            hi = g;
        }
        if (feasible_to_floor) lo = std::min(lo, hi);  // 0 unless γ_min says otherwise
    }
    while (lo > 0.0 && hi / lo - 1.0 > o.rel_tol) {
        const double mid = std::sqrt(lo * hi);
        if (feasible(mid)) hi = mid;
        else lo = mid;
    }
    r.gamma_opt = hi;
    r.gamma_lower = lo;
    r.gamma_controller = hi * (1.0 + o.backoff);
    GammaTest t = test_gamma(n, r.gamma_controller, o.riccati);
    if (!t.ok) {  // rounding at the boundary: fall back to the tested γ
        r.gamma_controller = hi;
        t = test_gamma(n, hi, o.riccati);
        if (!t.ok) throw SynthesisError("at γ = " + format::significant(hi, 4) + ": " + t.why);
    }
    r.residual_x = t.x.residual;
    r.residual_y = t.y.residual;
    r.cond_x = t.x.cond_u11;
    r.cond_y = t.y.cond_u11;
    r.rho_xy_over_gamma2 = t.rho / (r.gamma_controller * r.gamma_controller);
    r.controller = restore(n, central_controller(n, t, r.gamma_controller));
    r.closed_loop = lft_lower(plant.sys, r.controller);
    r.stable = is_stable(r.closed_loop);
    r.gamma = hinf_norm_mimo(r.closed_loop, 1e-7).norm;
    // Never hand out a controller that does not do what γ_K promises: when
    // the plant's data span more decades than double precision holds (a
    // weight of 0.44 at DC and 1e8 at ∞ puts its DC part 1e-16 below the
    // rest of C1'C1), the tests above can pass on rounding noise.
    // 1e-4: far above the norm's accuracy (1e-7), far below a real miss.
    if (!r.stable || !(r.gamma <= r.gamma_controller * (1.0 + 1e-4)))
        throw SynthesisError("the controller formed at γ = " + format::significant(r.gamma_controller, 4) + " achieves " +
                             (r.stable ? "||F_l(P, K)||∞ = " + format::significant(r.gamma, 4) : std::string("an unstable closed loop")) +
                             ": the problem is too ill-conditioned for double precision (a weight whose gain spans "
                             "too many decades? move its far poles or zeros in)");
    return r;
}

}  // namespace piezoloop::design
