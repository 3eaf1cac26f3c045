// Fit of a D-scaling magnitude |d(jω)| (the μ upper bound's optimal
// scaling of one uncertainty block, sampled on a frequency grid) by a
// stable, minimum-phase, biproper rational function of a given order — the
// "D step" of a D–K iteration (dk_iteration.hpp).
//
// Why this form. d(s) enters the generalised plant as d on the block's
// output and 1/d on its input (Zhou, Doyle & Glover, "Robust and Optimal
// Control", 1996, §11.3 and ch. 11's D–K iteration; Balas, Doyle, Glover,
// Packard & Smith, "μ-Analysis and Synthesis Toolbox User's Guide", 1991,
// ch. 6, `fitmag`/`musynfit`): both must be stable and proper, so d must be
// stable, minimum phase and biproper. Only |d(jω)| matters (a phase can be
// absorbed by the structure of a full complex block), so a magnitude fit is
// all that is needed.
//
// Method. The toolbox fits |d|² and takes a spectral factor; here the
// factored form is fitted directly, which makes stability and minimum phase
// hold by construction instead of by a factorisation afterwards:
//     d(s) = g Π_i (s + z_i) / Π_i (s + p_i),   z_i = e^{a_i}, p_i = e^{b_i} > 0,
//     log|d(jω)| = log g + ½ Σ log(ω² + z_i²) − ½ Σ log(ω² + p_i²),
// and the weighted least-squares error in log|d| (relative error in |d|,
// what matters for the scaled plant) is minimised over (log g, a, b) by
// Levenberg–Marquardt (Marquardt, SIAM J. Appl. Math. 11(2), 1963). The
// model is smooth in these parameters and its Jacobian is closed-form
// (∂/∂a_i = z_i² / (ω² + z_i²), ∂/∂b_i = −p_i² / (ω² + p_i²)). Real poles and
// zeros only: a D-scaling of a SISO loop is a smooth function of ω in
// practice (it follows ratios of closed-loop magnitudes), and real factors
// keep every order reachable. Orders are built up 0, 1, …, K, each order
// started from the previous fit (corners kept within the sampled band) plus a zero/pole pair placed at the largest
// residual, and from log-spaced interleaved zeros and poles; the best fit
// is kept (so the error never increases with the order).
#pragma once

#include <vector>

#include "lti/lti.hpp"

namespace piezoloop::design {

struct DFit {
    Zpk d;                         // stable, minimum phase, biproper; order() poles
    // max_k (w_k / max w) | |d(jω_k)| / m_k − 1 |: the relative error where
    // it matters (all weights equal: the plain maximum).
    double max_rel_error = 0.0;
    double rms_log_error = 0.0;    // weighted RMS of log|d| − log m
    int order = 0;
};

// Samples ω_k > 0 (rad/s, any order), magnitudes m_k > 0 and weights
// w_k >= 0 (empty: all 1). Throws std::invalid_argument naming the argument
// ("d fit: ...") for sizes that differ, non-positive ω or m, a negative
// order or one with fewer samples than 2 order + 1 parameters.
DFit fit_d_scaling(const std::vector<double>& w_rad_s, const std::vector<double>& magnitude,
                   const std::vector<double>& weight, int order);

}  // namespace piezoloop::design
