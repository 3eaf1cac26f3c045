// H∞ norm of a SISO state-space model, continuous or discrete, to a stated
// relative accuracy (not a grid maximum).
//
// Method: the Boyd–Balakrishnan / Bruinsma–Steinbuch level-set iteration.
// For γ > |D|, γ is a value of |G(jω)| exactly when the 2n×2n Hamiltonian
// H(γ) has the eigenvalue jω. Starting from a lower bound γ_lb (|G| at 0, ∞
// and at the natural frequencies of the poles), each step tests
// γ = (1 + 2 tol) γ_lb: the imaginary eigenvalues of H(γ) cut the frequency
// axis into intervals, |G| is evaluated at each interval's (geometric)
// midpoint and the largest value becomes the new γ_lb. The iteration is
// quadratically convergent; it stops when H(γ) has no imaginary eigenvalue
// or when no midpoint exceeds γ (both certify sup|G| <= γ, because every
// interval where |G| > γ is bounded by two such eigenvalues and therefore
// contains a midpoint). The answer satisfies lower <= ||G||∞ <= upper with
// upper / lower - 1 <= 2 tol, and lower is a value |G(jω_peak)| actually
// attained. A final golden-section search around ω_peak sharpens the peak
// frequency. Eigenvalues count as imaginary within 1e-3 |λ| (false
// positives are harmless). The Hamiltonian can be too ill-conditioned for
// its imaginary eigenvalues to be found at all: Ahmad2020's H_y T (a double
// pole at −7.5e7 rad/s with gain 1e8 behind a loop with poles down to
// 3 rad/s) is one. So, as a safety net, the result is compared with |G| on
// the analysis grid of margins.hpp (200 points per decade, clustered at
// lightly damped poles); if the grid beats it, the result is the grid
// maximum refined by golden-section search and `certified` is false
// (accurate to the evaluation, ~1e-8 there, but a peak narrower than the
// grid could in principle be missed).
//
// Discrete models are mapped to continuous ones by the bilinear map
// z = (1 + s) / (1 - s), which carries the unit circle onto the imaginary
// axis (e^{jθ} ↔ j tan(θ/2)) and so preserves the H∞ norm exactly; no
// symplectic pencil is needed. Before the eigenvalue problems the model is
// balanced (diagonal similarity, powers of 2) and, if continuous, its
// frequency axis is rescaled to the poles' magnitude, which keeps the
// Hamiltonian well scaled for models whose poles span 1 … 1e8 rad/s.
//
// For an unstable model the same iteration returns the L∞ norm (sup over the
// frequency axis) with `stable == false`; its H∞ norm is infinite. A pole on
// the axis gives an infinite peak.
#pragma once

#include <vector>

#include "lti/lti.hpp"

namespace piezoloop::design {

// Evaluates G at many points: A is reduced to Hessenberg form once, each
// point then costs O(n^2). ω in rad/s; discrete models are evaluated at
// z = exp(jω ts).
class SsEvaluator {
public:
    explicit SsEvaluator(const Ss& g);
    cplx at_s(cplx s) const;  // s (or z for discrete models) given directly
    cplx at_w(double w_rad_s) const;
    double ts() const { return ts_; }

private:
    Eigen::MatrixXd h_;  // Hessenberg form of A
    Eigen::VectorXd b_;  // Q^T B
    Eigen::RowVectorXd c_;  // C Q
    double d_ = 0.0;
    double ts_ = 0.0;
};

// Eigenvalues of A (continuous: s-plane, discrete: z-plane).
std::vector<cplx> ss_poles(const Ss& g);
// Max real part (continuous) or max |z| (discrete) of the poles; -inf / 0 when
// there are no states.
double stability_measure(const Ss& g);
// Continuous: all poles with Re < 0; discrete: all poles with |z| < 1.
bool is_stable(const Ss& g);

struct HinfResult {
    double norm = 0.0;   // best attained value |G(jω_peak)| (a lower bound)
    double lower = 0.0;  // == norm
    double upper = 0.0;  // certified upper bound of sup |G| on the axis
    double peak_w_rad_s = 0.0;  // frequency of the peak (rad/s); inf if at ω → ∞
    double peak_Hz = 0.0;
    bool stable = true;  // false: the value is the L∞ norm; H∞ is infinite
    bool peak_at_infinity = false;  // continuous: sup reached as ω → ∞ (|D|)
    // false: the analysis grid found a value above the iteration's bound (an
    // eigenvalue misjudged); norm is then that grid maximum refined by a
    // golden-section search, and upper == norm is not a certified bound.
    bool certified = true;
    int iterations = 0;
};

// rel_tol: requested relative accuracy (upper/lower - 1 <= 2 rel_tol),
// in [1e-12, 1e-2].
HinfResult hinf_norm(const Ss& g, double rel_tol = 1e-7);

// Helpers exposed for tests and the other analyses.
// Bilinear map of a discrete model to the continuous one with the same
// H∞ norm (see above). Requires -1 not to be a pole.
Ss bilinear_to_continuous(const Ss& g);

}  // namespace piezoloop::design
