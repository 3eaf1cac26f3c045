// Balanced truncation with Hankel singular values (docs/models.md, 'Identification'; how Ahmad2020
// and Janaideh2016 reduced their 36th/11th-order controllers to 6th/5th),
// for stable continuous or discrete SISO state-space models.
//
// Method (square-root balanced truncation):
//  1. A is scaled by a diagonal power-of-two similarity (Parlett–Reinsch
//     balancing, lti_convert's balance()); the transfer function and the
//     Hankel singular values are unchanged, and the Lyapunov solves see
//     comparable row/column norms.
//  2. Gramians from the Lyapunov equations
//       continuous: A P + P A' + B B' = 0,  A' Q + Q A + C' C = 0
//       discrete:   A P A' - P + B B' = 0,  A' Q A - Q + C' C = 0
//     by Bartels–Stewart on the complex Schur form A = U T U^H (column by
//     column triangular solves, O(n^3)).
//  3. P = Lp Lp', Q = Lq Lq' from symmetric eigendecompositions (negative
//     rounding-level eigenvalues set to zero: the Gramians of a nearly
//     non-minimal model are only semidefinite, where Cholesky would fail).
//  4. Lq' Lp = U S V'; the Hankel singular values are diag(S); with S1 the
//     leading N of them, Tl = S1^-1/2 U1' Lq', Tr = Lp V1 S1^-1/2 and the
//     reduced model is (Tl A Tr, Tl B, C Tr, D).
// The reduced model is stable (balanced too for continuous models; a
// truncated discrete balanced model in general is not), and for both time
// domains ||G - G_N||_inf <= 2 * sum_{i > N} sigma_i.
#pragma once

#include <vector>

#include <Eigen/Dense>

#include "lti/lti.hpp"

namespace piezoloop::design {

// A X + X A' + Q = 0 (A stable: no eigenvalue pair with lambda_i + conj(lambda_j) = 0).
Eigen::MatrixXd solve_lyapunov_continuous(const Eigen::MatrixXd& A, const Eigen::MatrixXd& Q);
// A X A' - X + Q = 0 (A stable: no pair with lambda_i conj(lambda_j) = 1).
Eigen::MatrixXd solve_lyapunov_discrete(const Eigen::MatrixXd& A, const Eigen::MatrixXd& Q);

struct BalancedTruncation {
    Ss reduced;               // order N, same ts as the input
    std::vector<double> hsv;  // Hankel singular values of the full model, descending
    double error_bound = 0.0; // 2 * sum_{i > N} hsv[i]
    int order = 0;
};

// Hankel singular values, descending. Throws std::invalid_argument naming
// the field ("A", "B", "C", "D", "model") for inconsistent sizes, NaN/Inf,
// an empty model, more than 200 states, or an unstable model (the message
// gives the offending pole).
std::vector<double> hankel_singular_values(const Ss& sys);

// Reduces to `order` states (1 <= order <= n). Throws as above, and names
// "order" when it is out of range or when sigma_order is at rounding level
// (only fewer states are both controllable and observable).
BalancedTruncation balanced_truncation(const Ss& sys, int order);

}  // namespace piezoloop::design
