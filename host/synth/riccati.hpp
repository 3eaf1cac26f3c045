// Continuous algebraic Riccati equations by the stable invariant subspace of
// the Hamiltonian (Laub 1979, "A Schur method for solving algebraic Riccati
// equations", IEEE TAC 24(6)).
//
//   A' X + X A - X R X + Q = 0,   R = R', Q = Q' (either may be indefinite)
//
// X is the stabilising solution (A - R X stable) when it exists. With
// H = [A, -R; -Q, -A'] and an ordered real Schur form H = U T U' whose
// leading n eigenvalues are the stable ones, X = U21 U11^-1.
//
// Scaling before the Schur form (both undone exactly afterwards):
//  * the off-diagonal blocks: X~ = X / c with c = sqrt(|Q| / |R|), which
//    makes |c R| = |Q / c| (the Hamiltonian's eigenvalues are unchanged);
//  * only if the solve with that alone fails: states by a diagonal
//    similarity x = D x~ with powers of two. (A fallback: hinfsyn balances
//    the plant's states already, and on the weighted Ahmad2020 plant the
//    H balanced once more lost its eigenvalues' ± symmetry where the
//    unbalanced one kept it.) The pair (top i, bottom i) of H must be
//    scaled by (d_i, 1/d_i) to stay
//    Hamiltonian, so d_i = sqrt(e_i / f_i) rounded to a power of two,
//    from a Parlett–Reinsch balancing diag(e, f) of |H| (the idea of
//    Benner's symplectic balancing, in its simplest form).
// The ordered Schur form is LAPACK's dgees with a selector for Re λ < 0
// (Fortran interface; Eigen has no reordering).
//
// Reported: the relative residual |A'X + XA - XRX + Q|_F / (2|A'X|_F +
// |XRX|_F + |Q|_F) (each term's own size, so a large X in a direction R
// does not see cannot hide an error), the condition number of U11 (the figure that
// governs the accuracy of X = U21 U11^-1: X is lost when it reaches
// 1/eps), and the smallest distance of H's eigenvalues from the imaginary
// axis relative to their magnitude, min |Re λ| / |λ| (the separation the
// splitting relies on).
#pragma once

#include <stdexcept>
#include <string>

#include <Eigen/Dense>

#include "lti/decompositions.hpp"

namespace piezoloop::design {

enum class RiccatiFailure {
    kNone,
    kImaginaryAxis,     // H has eigenvalues on the imaginary axis: no stabilising solution
    kSingularU11,       // the stable subspace is not a graph: no stabilising solution
    kResidual,          // a solution was found but its residual exceeds the limit
    kSchur,             // LAPACK failed (QR iteration or reordering)
};

struct RiccatiOptions {
    // Eigenvalues with |Re λ| <= axis_tol * |λ| count as imaginary (|λ|
    // floored at 1e-5 eps |H|, so a zero eigenvalue counts too). Imaginary
    // eigenvalues of a Hamiltonian are double (a Jordan pair), and rounding
    // moves them off the axis by O(sqrt(eps)) ~ 1.5e-8 relative: the
    // tolerance must be well above that. Near a γ boundary Re λ grows like
    // sqrt(γ - γ_b), so 1e-6 shifts the boundary by ~1e-12 relative only.
    double axis_tol = 1e-6;
    // Largest accepted relative residual (see above); a clean solve of a
    // scaled problem gives 1e-15 ... 1e-12.
    double max_residual = 1e-8;
};

struct RiccatiResult {
    Eigen::MatrixXd X;
    RiccatiFailure failure = RiccatiFailure::kNone;
    double residual = 0.0;     // relative, see above
    double cond_u11 = 0.0;     // 2-norm condition number of U11
    double axis_gap = 0.0;     // min |Re λ(H)| / |λ| (of the scaled H)
    bool ok() const { return failure == RiccatiFailure::kNone; }
};

// Power of two nearest x (x > 0): a scaling by it is exact in binary.
double pow2_near(double x);

// Thrown by the throwing solvers; `failure` says which condition failed.
class RiccatiError : public std::runtime_error {
public:
    RiccatiError(RiccatiFailure f, const std::string& what) : std::runtime_error(what), failure(f) {}
    RiccatiFailure failure;
};

// A' X + X A - X R X + Q = 0. Does not throw for the failures above (they
// are reported in `failure`; X is whatever the solve produced, or empty);
// throws std::invalid_argument for sizes that disagree or non-finite input.
RiccatiResult riccati_hamiltonian(const Eigen::MatrixXd& A, const Eigen::MatrixXd& R, const Eigen::MatrixXd& Q,
                                  const RiccatiOptions& options = {});

// The control CARE A' X + X A - X B Rw^-1 B' X + Q = 0 with Rw > 0: the
// stabilising X (A - B Rw^-1 B' X stable). Throws RiccatiError with the
// failing condition named: "no stabilising solution (eigenvalues on the
// imaginary axis)", "Riccati residual too large (X: 3.2e-05)", ...
RiccatiResult solve_care(const Eigen::MatrixXd& A, const Eigen::MatrixXd& B, const Eigen::MatrixXd& Q,
                         const Eigen::MatrixXd& Rw, const RiccatiOptions& options = {});

// Text of a failure for messages: "eigenvalues on the imaginary axis", ...
std::string riccati_failure_text(RiccatiFailure f);

}  // namespace piezoloop::design
