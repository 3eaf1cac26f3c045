// H∞ output-feedback synthesis for a continuous generalised plant
//
//       [ z ]   [ A  | B1   B2  ] [ x ]
//       [ y ] = [ C1 | D11  D12 ] [ w ]        u = K y
//               [ C2 | D21  D22 ] [ u ]
//
// (inputs [w; u], outputs [z; y], sizes n_w, n_u, n_z, n_y): the smallest
// γ for which a stabilising K makes ||F_l(P, K)||∞ < γ, found by bisection,
// and the central controller at that γ.
//
// Formulas: the general state-space solution of Glover & Doyle (1988),
// "State-space formulae for all stabilizing controllers that satisfy an
// H∞-norm bound and relations to risk sensitivity", Systems & Control
// Letters 11, in the form of Zhou, Doyle & Glover (1996), "Robust and
// Optimal Control", chapter 17 ("H∞ control: general case"):
// with D12 = [0; I], D21 = [0 I] and D22 = 0 (reached as below),
// D1. = [D11 D12], D.1 = [D11; D21], B = [B1 B2], C = [C1; C2],
//   R  = D1.'D1. - diag(γ² I, 0),       R~ = D.1 D.1' - diag(γ² I, 0),
//   X∞ = Ric([A 0; -C1'C1 -A'] - [B; -C1'D1.] R^-1 [D1.'C1  B']),
//   Y∞ = Ric([A' 0; -B1 B1' -A] - [C'; -B1 D.1'] R~^-1 [D.1 B1'  C]),
//   F = -R^-1 (D1.'C1 + B'X∞),           L = -(B1 D.1' + Y∞ C') R~^-1,
// a controller exists iff γ > max(σ̄[D1111 D1112], σ̄[D1111' D1121']),
// X∞ >= 0 and Y∞ >= 0 are stabilising solutions, and ρ(X∞ Y∞) < γ²;
// the central controller is then (Â, B̂1, Ĉ1, D̂11) of ZDG's formulas
// (hinfsyn.cpp, central_controller). D11 ≠ 0 needs no loop shifting in
// this form.
//
// Reaching the normal form (undone on the controller afterwards):
//  * states balanced (diagonal, powers of two) and the frequency axis
//    scaled by ω0 (a power of two near the geometric mean of the poles'
//    magnitudes): s = ω0 s~, so a plant whose poles span 3 … 1e5 rad/s
//    (Ahmad2020's G(s) with its weights) gives O(1) Hamiltonians;
//  * D12 = U [0; Σ] V' (SVD): z~ = U'z and u = V Σ^-1 u~ make D12~ = [0; I];
//    D21 = U~ [0 Σ~] V~': w~ = V~'w and y~ = Σ~^-1 U~'y make D21~ = [0 I]
//    (orthogonal on w and z, so the norm is unchanged — ZDG section 17.2);
//  * D22 ≠ 0 by loop shifting (Safonov, Limebeer & Chiang 1989, "Simplifying
//    the H∞ theory via loop-shifting, matrix-pencil and descriptor
//    concepts", Int. J. Control 50(6)): synthesise K0 for the plant with
//    D22 = 0, then K = K0 (I + D22 K0)^-1.
//
// Existence tests that do not depend on γ are made first, each failure
// named: D12 of full column rank, D21 of full row rank, (A, B2)
// stabilisable, (C2, A) detectable (Hautus tests at the modes with
// Re λ >= 0), and [A - jωI B2; C1 D12] of full column rank and
// [A - jωI B1; C2 D21] of full row rank for all ω — tested where it
// matters: at the imaginary-axis eigenvalues of the γ = ∞ (H2) Hamiltonians,
// which are exactly the ω where these lose rank.
//
// γ iteration: bisection in log γ on [lo, hi]; lo defaults to the D11
// bound above, hi to the first of 1, 10, 100, … (up to 1e15, Octave's
// GMAX) where the tests pass. It stops when hi / lo - 1 <= rel_tol
// (default 1e-6, what the issue asks of the Octave reference; ~25
// iterations over 6 decades). The controller is formed at γ_K = hi (1 +
// backoff): exactly at the optimum I - γ^-2 Y∞X∞ is singular and the
// central controller has poles at infinity; the default backoff 1e-3 keeps
// them finite at a cost of 0.1 % in γ.
#pragma once

#include <stdexcept>
#include <string>

#include "synth/riccati.hpp"
#include "synth/state_space.hpp"

namespace piezoloop::design {

struct GeneralisedPlant {
    StateSpace sys;   // inputs [w; u], outputs [z; y]
    int n_w = 0, n_u = 0, n_z = 0, n_y = 0;
};

// Throws std::invalid_argument "<what>: ..." for partition sizes that do
// not match the matrices, an empty partition or non-finite entries.
void check_plant(const GeneralisedPlant& p, const std::string& what = "plant");

struct HinfOptions {
    double rel_tol = 1e-6;    // bisection stops at hi / lo - 1 <= rel_tol
    double gamma_min = 0.0;   // 0: from the D11 bound
    double gamma_max = 0.0;   // 0: search 1, 10, ... 1e15
    double backoff = 1e-3;    // controller at γ_K = γ_hi (1 + backoff)
    RiccatiOptions riccati;
};

struct HinfSynthesis {
    StateSpace controller;        // y -> u, continuous
    double gamma_opt = 0.0;       // smallest γ that passed the tests (within rel_tol of the optimum)
    double gamma_lower = 0.0;     // largest γ that failed (or the lower end)
    double gamma_controller = 0.0;  // γ_K the controller was formed at
    double gamma = 0.0;           // achieved: ||F_l(P, K)||∞ recomputed (<= γ_K)
    bool stable = false;          // closed loop
    int iterations = 0;
    double residual_x = 0.0, residual_y = 0.0;  // relative Riccati residuals at γ_K
    double cond_x = 0.0, cond_y = 0.0;          // cond(U11) of each
    double rho_xy_over_gamma2 = 0.0;            // ρ(X∞Y∞) / γ_K²
    double w0_rad_s = 1.0;                      // frequency scaling used
    StateSpace closed_loop;
};

// Synthesis failed for a reason of the problem (not of the input's form):
// the message names the condition, e.g. "D12 not of full column rank",
// "(A, B2) not stabilisable (mode at 1 + 0j rad/s)", "no γ in the search
// interval [0.1, 10]: at γ = 10, ρ(X∞Y∞) >= γ²", "Riccati residual too
// large (X: 3.2e-05)".
class SynthesisError : public std::runtime_error {
public:
    using std::runtime_error::runtime_error;
};

HinfSynthesis hinfsyn(const GeneralisedPlant& plant, const HinfOptions& options = {});

}  // namespace piezoloop::design
