// Structured singular value μ of a complex matrix for a structure of full
// complex blocks: an upper bound by D-scaling and a lower bound from an
// explicit perturbation, and the loop interconnection `analyze mu` sweeps.
//
// Structure. Δ = diag(Δ_1, …, Δ_F), Δ_i ∈ C^{w_i × z_i}: block i takes the
// z_i outputs of M in row block i and feeds the w_i inputs of M in column
// block i, so M is (Σ z_i) × (Σ w_i). Square full blocks have z_i = w_i
// (a scalar block is 1 × 1); non-square blocks are allowed as they are, no
// padding: the performance block of a loop with several weighted outputs and
// one reference input is 1 × p. μ(M) = 1 / min{σ̄(Δ) : det(I − M Δ) = 0}.
//
// Upper bound (Packard & Doyle, "The complex structured singular value",
// Automatica 29(1), 1993, §6): for D_z = diag(d_i I_{z_i}) and
// D_w = diag(d_i I_{w_i}), d_i > 0, D_w Δ D_z⁻¹ = Δ, hence
//     μ(M) ≤ inf_d σ̄(D_z M D_w⁻¹),   d_F = 1 (only ratios matter).
// With x = log d, φ(x) = log σ̄(e^X M e^{−X}) is convex (Sezginer & Overton,
// IEEE TAC 35(2), 1990), so every local minimum is global. Where σ̄ is
// simple, with unit singular vectors u (rows) and v (columns) split by
// block, ∂φ/∂x_i = ‖u_i‖² − ‖v_i‖².
//   1. Start: Osborne's balancing (Osborne, J. ACM 7, 1960) of the F × F
//      matrix of block Frobenius norms B_ij = ‖M_ij‖_F, which minimises the
//      Frobenius norm of the scaled block-norm matrix, an upper bound of σ̄.
//   2. One free scaling (F = 2, the robust-performance problem of a SISO
//      loop): bracket and golden-section search on the convex φ, to
//      1e-10 in x (no reliance on smoothness at the optimum, where σ̄ is
//      often repeated).
//      More: BFGS with a weak Wolfe line search, which Lewis & Overton
//      ("Nonsmooth optimization via quasi-Newton methods", Math. Prog. 141,
//      2013) show to converge on nonsmooth convex functions like φ, followed
//      by cyclic golden-section passes per coordinate that can only lower φ.
// Lower bound: μ(M) ≥ ρ(M Δ) for any Δ of the structure with σ̄(Δ) ≤ 1.
// Start from the aligned perturbation Δ_i = v_i u_iᴴ / (‖v_i‖ ‖u_i‖) of the
// scaled matrix's top singular pair (exact, lower = upper, when σ̄ is simple
// at the optimum: Packard & Doyle Thm 6.4), then a few steps of the
// power-iteration idea of Packard, Fan & Doyle (CDC 1988): with the dominant
// right/left eigenvectors x, y of M Δ, a = Mᴴ y, take
// Δ_i = a_i x_iᴴ / (‖a_i‖ ‖x_i‖), which adds every block's contribution to
// yᴴ M Δ x in phase; the largest ρ met is kept. Whatever the iteration does,
// the value reported is ρ(M Δ) of an explicit admissible Δ: a true bound.
#pragma once

#include <vector>

#include "lti/lti.hpp"

namespace piezoloop::design {

struct MuBlock {
    int z_size = 1;  // rows of M the block reads (inputs of Δ_i)
    int w_size = 1;  // columns of M the block drives (outputs of Δ_i)
};

struct MuBound {
    double upper = 0.0;  // inf_d σ̄(D_z M D_w⁻¹) as found
    double lower = 0.0;  // ρ(M Δ) of an admissible Δ, σ̄(Δ) <= 1
    // Optimal scalings d_i, one per block, d_last = 1: what a D–K iteration
    // fits with rational functions of frequency.
    std::vector<double> d;
    int evaluations = 0;  // singular value decompositions spent
};

// Throws std::invalid_argument when the blocks do not tile M or M is not
// finite. `d_start` (optional, one per block, positive) replaces Osborne's
// start: a sweep passes the previous frequency's optimum.
MuBound mu_bounds(const Eigen::MatrixXcd& m, const std::vector<MuBlock>& blocks,
                  const std::vector<double>& d_start = {});

// σ̄(D_z M D_w⁻¹) for given scalings (exposed for tests and brute force).
double scaled_sigma_max(const Eigen::MatrixXcd& m, const std::vector<MuBlock>& blocks, const std::vector<double>& d);

// ---------------------------------------------------------------- loop
//
// SISO loop e = r − y, u = K e, uncertain plant G_p = G (1 + Δ H_m),
// |Δ| <= 1 (multiplicative, input = output for SISO). Uncertainty channel
// w_Δ → G's input added to u, z_Δ = H_m u; performance outputs
// z_e = W1 e, and optionally z_y = W3 y, z_u = W2 u, driven by r. With
// S = 1/(1+GK), T = GK S:
//     [z_Δ]   [ −H_m T    H_m K S ] [w_Δ]
//     [z_e] = [ −W1 G S   W1 S    ] [ r ]
//     [z_y]   [  W3 G S   W3 T    ]
//     [z_u]   [ −W2 T     W2 K S  ]
// Structures: robust stability {1×1} on N11 (μ = |H_m T|); nominal
// performance σ̄(N22) = sqrt(|W1 S|² + |W3 T|² + |W2 KS|²) (one full 1 × p
// block: the stacked, mixed-sensitivity criterion, stricter than each norm
// alone); robust performance {1×1, 1×p} on N. All three need the nominal
// loop to be internally stable (checked by the caller, see mu_loop).

struct MuLoopModels {
    Zpk plant, controller, hm, w1;
    bool has_w3 = false, has_w2 = false;
    Zpk w3, w2;
};

struct MuPoint {
    double w_rad_s = 0.0;
    double rs = 0.0;        // |H_m T|
    double np = 0.0;        // σ̄(N22)
    double rp_upper = 0.0;  // μ upper bound of N
    double rp_lower = 0.0;  // μ lower bound of N
    std::vector<double> d;  // optimal scalings {d_Δ, d_P = 1}
};

// N at one frequency (rows z_Δ, z_e[, z_y][, z_u]; columns w_Δ, r).
Eigen::MatrixXcd mu_loop_matrix(const MuLoopModels& models, double w_rad_s);
// All three measures at one frequency; d_start as in mu_bounds.
MuPoint mu_loop_point(const MuLoopModels& models, double w_rad_s, const std::vector<double>& d_start = {});

struct MuPeak {
    double value = 0.0;
    double w_rad_s = 0.0;
    double lower = 0.0;  // RP only: the lower bound at that frequency
};

struct MuLoopResult {
    bool nominally_stable = false;
    double stability_measure = 0.0;  // max Re(pole) (rad/s) or max |z|
    std::vector<MuPoint> points;     // the analysis grid, ascending ω
    MuPeak rs, np, rp;               // refined around the grid maxima
    double max_gap = 0.0;            // largest relative (upper − lower) / upper over the grid
};

// Sweeps the analysis grid of margins.hpp built on the poles and zeros of
// every model and of the closed loop, then refines each peak by a
// golden-section search in log ω between the grid neighbours of the
// maximum. All models continuous, or discrete with one ts.
MuLoopResult mu_loop(const MuLoopModels& models);

}  // namespace piezoloop::design
