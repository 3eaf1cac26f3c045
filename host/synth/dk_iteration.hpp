// μ-synthesis by D–K iteration for a SISO loop with an input-multiplicative
// uncertainty, G_p = G (1 + Δ H_m), |Δ(jω)| <= 1, and the performance
// weights of mixed sensitivity (`piezoloop design musyn`, docs/synthesis.md).
//
// Signals (u = K e: the controller sees the error, as in mixsyn and in
// analysis/mu.hpp's loop):
//   w_Δ  uncertainty input: added to the plant input, G is driven by u + w_Δ
//   r    reference
//   u    control (controller output)
//   y    = G (u + w_Δ)          plant output
//   e    = r − y                measured by the controller
//   z_Δ  = H_m u                uncertainty output (Δ closes w_Δ = Δ z_Δ)
//   z_e  = W1 e,  z_y = W3 y,  z_u = W2 u   performance outputs
// Generalised plant P: inputs [w_Δ; r; u], outputs [z_Δ; z_e; z_y; z_u; e]
// (z_y / z_u only with W3 / W2), partition n_w = 2, n_u = 1, n_z = 1 + p,
// n_y = 1; states of G, H_m, W1, W3, W2 stacked in that order, each realised
// from its factored form. Its closed loop F_l(P, K) from [w_Δ; r] to
// [z_Δ; z_e; z_y; z_u] is exactly analysis/mu.hpp's N (mu_loop_matrix), so
// robust performance is μ of N for the structure {1×1 (Δ), 1×p (performance)}.
//
// D–K iteration (Doyle, "Structured uncertainty in control system design",
// CDC 1985; Zhou, Doyle & Glover, "Robust and Optimal Control", 1996,
// §11.3 / ch. 11; Balas et al., μ-Analysis and Synthesis Toolbox, 1991):
//   0. d(s) = 1.
//   1. K step: K = hinfsyn of the scaled plant diag(d, I) P diag(1/d, I, I)
//      (d on z_Δ, 1/d on w_Δ; the performance block's scaling is 1), γ its
//      achieved norm: σ̄ of the D-scaled N, an upper bound of μ on the
//      fitted d.
//   2. D step: μ upper bound of N = F_l(P, K) (unscaled) on a log grid with
//      the optimal scalings d_Δ(ω) (mu_bounds, warm-started from the
//      neighbour); its peak is the iteration's μ.
//   3. Fit |d_Δ(jω)| by a stable minimum-phase biproper d(s) of order K
//      (d_fit.hpp), weighted by μ(ω)/μ_peak (the fit only matters where μ is
//      near its peak), and go to 1.
// It stops after `iterations` K steps or when μ falls by less than
// `min_improvement` (relative) from one iteration to the next; the
// controller with the lowest μ peak is returned. Each iteration adds 2 K
// states to the plant and so to the controller: n_K = n_P + 2 K.
#pragma once

#include <functional>
#include <optional>
#include <string>
#include <vector>

#include "analysis/mu.hpp"
#include "lti/lti.hpp"
#include "synth/hinfsyn.hpp"

namespace piezoloop::design {

struct MusynProblem {
    Zpk plant, w1, hm;
    std::optional<Zpk> w2, w3;
};

struct DkRecord {
    int iteration = 0;              // 1-based
    double gamma = 0.0;             // achieved H∞ norm of the scaled closed loop
    double mu_peak = 0.0;           // max over the grid of the μ upper bound of N
    double mu_peak_w_rad_s = 0.0;
    int controller_order = 0;
    int plant_order = 0;            // the (scaled) plant hinfsyn saw
    Zpk d_used;                     // the d(s) of this K step (1 in iteration 1)
    double d_fit_max_rel_error = 0.0;  // of the fit made after this iteration (0 if none)
    double seconds = 0.0;
};

struct MusynOptions {
    int iterations = 4;             // K steps at most (>= 1)
    int d_order = 4;                // order of the fitted d(s) (>= 0)
    double min_improvement = 0.01;  // stop when μ_i > μ_{i-1} (1 − this)
    int points_per_decade = 25;     // μ grid density
    HinfOptions hinf;
    // Called after each iteration (the CLI prints progress on stderr).
    std::function<void(const DkRecord&)> on_iteration;
};

struct MusynResult {
    std::vector<DkRecord> records;
    int best = 0;                   // index into records of the returned controller
    std::string stop_reason;
    StateSpace controller;          // e -> u
    Ss controller_siso;
    Zpk controller_zpk;
    double gamma = 0.0;             // of the returned controller's K step
    bool stable = false;            // nominal closed loop
    int order = 0;
    int plant_order = 0;            // unscaled generalised plant
};

// The generalised plant above. Throws std::invalid_argument naming the
// model ("hm: weight is unstable (pole at ...)", "w3: weight is improper
// ...", "plant: ...").
GeneralisedPlant musyn_plant(const MusynProblem& problem);

// diag(d, I) P diag(1/d, I): d on the first output, 1/d on the first input.
// d must be continuous, stable, minimum phase and biproper (invalid_argument
// otherwise).
GeneralisedPlant scale_plant(const GeneralisedPlant& p, const Zpk& d);

// μ upper bound of F_l(P, K) on `grid` (rad/s): values and d_Δ per point.
struct MuSweep {
    std::vector<double> w_rad_s, mu, d;
    double peak = 0.0, peak_w_rad_s = 0.0;
    bool stable = false;
};
MuSweep mu_sweep(const GeneralisedPlant& p, const StateSpace& k, const std::vector<double>& grid);

// Log grid covering the poles of P a decade beyond on each side.
std::vector<double> musyn_grid(const GeneralisedPlant& p, int points_per_decade);

// Throws std::invalid_argument for bad input (weights, options) and
// SynthesisError when the first K step has no solution (a later failure
// ends the iteration with the best controller so far; stop_reason says so).
MusynResult musyn(const MusynProblem& problem, const MusynOptions& options = {});

}  // namespace piezoloop::design
