// H∞ norm of a stable MIMO continuous state-space model (the largest
// singular value of G(jω) over ω), to a stated relative accuracy. Synthesis
// reports the achieved γ of its controller with it; the SISO channels are
// also checked with analysis/hinf.hpp (the project's certified SISO norm).
//
// Method: the level-set iteration of Boyd & Balakrishnan (1990) and
// Bruinsma & Steinbuch (1990) for MIMO systems: for γ > σ̄(D), σ̄(G(jω)) = γ
// exactly when jω is an eigenvalue of the Hamiltonian (Boyd, Balakrishnan,
// Kabamba 1989)
//   H(γ) = [A - B R^-1 D'C,   -γ B R^-1 B';  γ C' S^-1 C,   -A' + C'D R^-1 B'],
//   R = D'D - γ² I, S = DD' - γ² I.
// From a lower bound (σ̄ at 0, ∞, the poles' magnitudes and a coarse grid),
// each step tests γ = (1 + 2 tol) γ_lb; σ̄ at the midpoints of the
// intervals its imaginary eigenvalues cut out becomes the new bound; no
// imaginary eigenvalue, or no midpoint above γ, ends it. The model is
// balanced and its frequency axis scaled first (as analysis/hinf.hpp).
#pragma once

#include "synth/state_space.hpp"

namespace piezoloop::design {

struct MimoHinf {
    double norm = 0.0;          // attained σ̄(G(jω_peak)) (lower bound)
    double upper = 0.0;         // certified bound (upper / norm - 1 <= 2 rel_tol)
    double peak_w_rad_s = 0.0;  // inf: at ω -> ∞
    bool stable = true;         // false: norm is the L∞ norm, H∞ is infinite
};

MimoHinf hinf_norm_mimo(const StateSpace& g, double rel_tol = 1e-7);

}  // namespace piezoloop::design
