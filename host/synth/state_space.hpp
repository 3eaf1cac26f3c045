// Multi-input multi-output continuous state-space models for synthesis
// (host/lti's Ss is SISO): the generalised plant of an H∞ problem, its
// controller and their closed loop. Time is continuous throughout (s in
// rad/s); a discrete controller comes from `design c2d` afterwards.
#pragma once

#include <complex>
#include <string>

#include <Eigen/Dense>

#include "lti/lti.hpp"

namespace piezoloop::design {

// x' = A x + B u, y = C x + D u.
struct StateSpace {
    Eigen::MatrixXd A, B, C, D;

    Eigen::Index states() const { return A.rows(); }
    Eigen::Index inputs() const { return B.cols(); }
    Eigen::Index outputs() const { return C.rows(); }
};

// Throws std::invalid_argument "<what>: ..." if the sizes disagree or an
// entry is NaN or infinite.
void check_state_space(const StateSpace& g, const std::string& what);

StateSpace from_siso(const Ss& g);  // requires a continuous model
Ss to_siso(const StateSpace& g, Eigen::Index output = 0, Eigen::Index input = 0);  // one channel

// G(s) at complex s: C (sI - A)^-1 B + D.
Eigen::MatrixXcd evaluate(const StateSpace& g, std::complex<double> s);

// Lower linear fractional transformation: P's last n_y outputs feed K, K's
// outputs are P's last n_u inputs (u = K y, positive feedback, as hinfsyn
// and Octave's lft). Throws std::domain_error if I - D22 DK is singular
// (the loop is not well posed).
StateSpace lft_lower(const StateSpace& p, const StateSpace& k);

// Diagonal similarity x = T x~ by powers of two (exact) that balances the
// rows and columns of [A B; C 0] over the states (LAPACK gebal's
// Parlett–Reinsch iteration, no permutation; as MATLAB's ssbal). The
// transfer function is unchanged.
StateSpace balance_states(const StateSpace& g);

// All eigenvalues of A in the open left half plane (no states: true).
bool is_stable(const StateSpace& g);

}  // namespace piezoloop::design
