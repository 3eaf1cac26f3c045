// Riccati solver (host/synth/riccati) against closed-form solutions, the
// Lyapunov equation it must satisfy, and its failure modes.
#include <cmath>

#include <gtest/gtest.h>

#include <Eigen/Eigenvalues>

#include "ident/balred.hpp"
#include "synth/riccati.hpp"

using namespace piezoloop::design;

namespace {

Eigen::MatrixXd m1(double x) { return Eigen::MatrixXd::Constant(1, 1, x); }

double max_real_eig(const Eigen::MatrixXd& a) {
    return a.eigenvalues().real().maxCoeff();
}

}  // namespace

// Scalar CARE 2 a x - (b^2 / r) x^2 + q = 0: the stabilising root is
// x = r (a + sqrt(a^2 + b^2 q / r)) / b^2 (closed loop a - b^2 x / r =
// -sqrt(a^2 + b^2 q / r) < 0). Tolerance 1e-13 relative: a few roundings
// of O(1) numbers.
TEST(Riccati, ScalarClosedForm) {
    for (double a : {-3.0, 0.0, 2.5}) {
        const double b = 0.7, q = 4.0, r = 0.3;
        const RiccatiResult s = solve_care(m1(a), m1(b), m1(q), m1(r));
        const double x = r * (a + std::sqrt(a * a + b * b * q / r)) / (b * b);
        EXPECT_NEAR(s.X(0, 0), x, 1e-13 * x) << "a = " << a;
        EXPECT_LT(s.residual, 1e-14);
        EXPECT_GE(s.cond_u11, 1.0);
    }
}

// Double integrator A = [0 1; 0 0], B = [0; 1], Q = I, R = 1: writing out
// the three scalar equations gives x12 = 1, x22 = sqrt(3), x11 = x22
// (x12^2 = q11, x11 = x12 x22, x22^2 = 2 x12 + q22).
TEST(Riccati, DoubleIntegratorClosedForm) {
    Eigen::MatrixXd A(2, 2), B(2, 1);
    A << 0, 1, 0, 0;
    B << 0, 1;
    const RiccatiResult s = solve_care(A, B, Eigen::MatrixXd::Identity(2, 2), m1(1.0));
    Eigen::MatrixXd x(2, 2);
    x << std::sqrt(3.0), 1, 1, std::sqrt(3.0);
    EXPECT_LT((s.X - x).norm(), 1e-13);
    EXPECT_LT(max_real_eig(A - B * B.transpose() * s.X), 0.0);
}

// The solution of a scaled, 8-state problem whose entries span 1e-3 ... 1e6:
// the closed loop Ac = A - R X is stable, and X satisfies the Lyapunov
// equation Ac' X + X Ac + X R X + Q = 0 (the Riccati equation rewritten
// around the closed loop), checked with the independent Bartels–Stewart
// solver of ident/balred. Tolerance 1e-9 relative: X's condition here is
// ~1e4, times eps ~ 2e-12, plus the Lyapunov solver's own error.
TEST(Riccati, IllScaledAgreesWithLyapunov) {
    const int n = 8;
    Eigen::MatrixXd A = Eigen::MatrixXd::Zero(n, n);
    Eigen::MatrixXd B = Eigen::MatrixXd::Zero(n, 2);
    for (int k = 0; k < n / 2; ++k) {
        const double w = std::pow(10.0, k + 0.0), z = 0.02;  // lightly damped modes 1 ... 1e3 rad/s
        A(2 * k, 2 * k + 1) = w;
        A(2 * k + 1, 2 * k) = -w;
        A(2 * k + 1, 2 * k + 1) = -2 * z * w;
        B(2 * k + 1, k % 2) = std::pow(10.0, 2.0 * k - 3.0);
    }
    const Eigen::MatrixXd Q = Eigen::MatrixXd::Identity(n, n);
    const Eigen::MatrixXd Rw = Eigen::MatrixXd::Identity(2, 2);
    const RiccatiResult s = solve_care(A, B, Q, Rw);
    // Residual relative to the terms' own sizes: eps times the spread of
    // B (1e-3 ... 1e3, squared in R) gives ~1e-11.
    EXPECT_LT(s.residual, 1e-9);
    const Eigen::MatrixXd R = B * B.transpose();
    const Eigen::MatrixXd ac = A - R * s.X;
    EXPECT_LT(max_real_eig(ac), 0.0);
    const Eigen::MatrixXd x2 = solve_lyapunov_continuous(ac.transpose(), Q + s.X * R * s.X);
    // Two solvers agree to eps times the closed loop's conditioning (modes
    // 1 ... 1e3 rad/s, input gains 1e-3 ... 1e3): 1e-9 .. 1e-8 of |X|,
    // depending on the last bits of libm and LAPACK (4.6e-8 / 3.6e-8 seen).
    EXPECT_LT((x2 - s.X).norm(), 1e-8 * s.X.norm());
}

// H∞-type equation with an indefinite R = B2 B2' - B1 B1' / γ^2 (scalar
// A = -1, B1 = B2 = C1 = 1): 2 a x - (1 - 1/γ^2) x^2 + 1 = 0 has the
// stabilising root x = (a + sqrt(a^2 + k)) / k, k = 1 - 1/γ^2, for γ > 1.
TEST(Riccati, IndefiniteR) {
    const double a = -1.0, gamma = 2.0, k = 1.0 - 1.0 / (gamma * gamma);
    const RiccatiResult s = riccati_hamiltonian(m1(a), m1(k), m1(1.0));
    ASSERT_TRUE(s.ok());
    EXPECT_NEAR(s.X(0, 0), (a + std::sqrt(a * a + k)) / k, 1e-14);
}

// A mode on the imaginary axis that B cannot reach and Q sees: the
// Hamiltonian keeps it, so there is no stabilising solution.
TEST(Riccati, ImaginaryAxisIsReported) {
    Eigen::MatrixXd A(2, 2), B(2, 1);
    A << 0, 1, -1, 0;  // undamped oscillator at 1 rad/s
    B << 0, 0;
    try {
        solve_care(A, B, Eigen::MatrixXd::Identity(2, 2), m1(1.0));
        FAIL() << "no error";
    } catch (const RiccatiError& e) {
        EXPECT_EQ(e.failure, RiccatiFailure::kImaginaryAxis);
        EXPECT_NE(std::string(e.what()).find("imaginary axis"), std::string::npos) << e.what();
    }
}

// An unstable mode B cannot reach and Q does not see: the Hamiltonian's
// stable subspace exists but is not a graph (U11 singular) — the
// stabilising solution does not exist, although a solution does.
TEST(Riccati, UnstabilisableIsReported) {
    Eigen::MatrixXd A(2, 2), B(2, 1), Q(2, 2);
    A << 1, 0, 0, -1;
    B << 0, 1;
    Q << 0, 0, 0, 1;
    const RiccatiResult s = riccati_hamiltonian(A, B * B.transpose(), Q);
    EXPECT_FALSE(s.ok());
    EXPECT_TRUE(s.failure == RiccatiFailure::kSingularU11 || s.failure == RiccatiFailure::kImaginaryAxis);
}

// A residual limit below what double precision can reach is reported as
// such, with the residual in the message.
TEST(Riccati, ResidualLimit) {
    Eigen::MatrixXd A(2, 2), B(2, 1);
    A << 0, 1, 0, 0;
    B << 0, 1;
    RiccatiOptions o;
    o.max_residual = 0.0;
    try {
        solve_care(A, B, Eigen::MatrixXd::Identity(2, 2), m1(1.0), o);
        // An exact zero residual is possible in principle; then there is nothing to report.
    } catch (const RiccatiError& e) {
        EXPECT_EQ(e.failure, RiccatiFailure::kResidual);
        EXPECT_NE(std::string(e.what()).find("Riccati residual too large (X: "), std::string::npos) << e.what();
    }
}
