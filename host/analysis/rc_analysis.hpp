// Stability analysis of the plug-in repetitive controller, docs/models.md, 'Repetitive control'
// (Shan2012 §2.1, §5), for a discrete closed loop T(z) (the feedback loop
// without RC) and the RC parameters N, m1, m2, k_rc, Q(z).
//
// RC(z) = k_rc z^m2 H / (1 − H),  H = Q(z) z^(m1 − N),  u = Gc (1 + RC) e.
// With S_rc = S / (1 + T RC) and 1 + T RC = (1 − H (1 − k_rc z^m2 T)) / (1 − H),
// the RC loop is stable iff T is and the roots of 1 − M(z),
// M = Q z^(m1−N) (1 − k_rc z^m2 T), lie inside the unit circle. What is
// evaluated (θ = θT + θ2, T(e^{jωTs}) = A e^{jθT}, θ2 = m2 ω Ts, θT unwrapped
// from ω = 0):
//
//  (1) small gain, sufficient for the above: sup over 0 < ω <= π/Ts of
//      |Q(e^{jωTs})| |1 − k_rc e^{jθ2} T| < 1 (the z^(m1−N) factor has modulus
//      1). Eq. (2)–(3) are this condition with Q z^m1 ≈ 1:
//  (2) 0 < k_rc < 2 cos θ / A for all ω up to Q's cutoff: reported as
//      k_rc_max = min over (0, ω_c] of 2 cos θ / A;
//  (3) |θ| < 90° for all ω up to Q's cutoff: reported as the max |θ|, and
//      the lowest frequency at which |θ| reaches 90° — the highest usable
//      Q cutoff.
//  exact: the eigenvalues of a state-space realisation of M closed in
//      positive unity feedback (N − m1 delay states) give the largest |z| of
//      the roots of 1 − M (computed when N − m1 <= max_exact_delay_states).
//
// With hysteresis modelled as PI (eq. 11–12, 15, 21), read as follows. The
// linear loop (T, or the loop gain L = Gc Gp given directly) is the loop
// with the hysteresis replaced by the identity v = u. The PI hysteresis is
// v = g0 u + η, η = g1 + Σ_j d(γ_j) F_γj[g0 u + g1], so the actual linear
// part of the loop is g0 L_rc with L_rc = L (1 + RC), and
//  (15) g0 <= M_GL, the (upper) gain margin of L_rc: the smallest factor
//       k > 1 with 1/k = |L_rc| where L_rc is real and negative (found on a
//       grid of max(20000, 64 N) points up to Nyquist, bisected); also the
//       loop g0 L_rc is checked for stability directly by its eigenvalues;
//  (21) G2 = η → u = −L_rc / (1 + g0 L_rc). The play operator has incremental
//       gain 1, so |η| grows at most like |g0| Σ_j |d(γ_j)| |u| and the small-
//       gain condition is ||d||_1 = Σ_j |d(γ_j)| < 1 / (|g0| ||G2||∞). Since
//       |g0| |G2| = |T_g0| with T_g0 = g0 L_rc / (1 + g0 L_rc) (the closed
//       loop with RC and the hysteresis gain), ||G2||∞ is computed as
//       ||T_g0||∞ / |g0| — by hinf_norm on its state space when that has at
//       most 800 states, otherwise as the maximum on the dense grid refined
//       by golden-section search. "sup_j ||d(γ_j)||_1" of Shan2012 is read as
//       the l1 norm of the density sequence (for a positive density it is the
//       sup over n of the partial sums): with the PI sum of docs/models.md, whose weights
//       are d(γ_j) themselves, that is the incremental gain of η. If the
//       density samples a continuous d(γ) (Shan2012's integral form), the
//       integral ρ Σ |d_j| is reported beside it.
//  If (21) fails, inverse-PI feedforward is required (Shan2012).
#pragma once

#include <optional>
#include <string>
#include <vector>

#include "lti/lti.hpp"

namespace piezoloop::design {

struct RcConfig {
    int period_samples = 100;  // N
    int m1 = 6;
    int m2 = 0;
    double k_rc = 0.8;
    Zpk q;  // discrete, same ts as the loop
    // The exact check (eigenvalues, O(N^3)) only up to this many delay
    // states N − m1; above it rc_max_abs_root and rc_stable stay empty.
    int max_exact_delay_states = 4000;
};

struct PiHysteresis {
    double g0 = 1.0;
    std::vector<double> density;  // d(γ_j), j = 1..n
    // Threshold spacing ρ when the density samples a continuous d(γ)
    // (γ_j = ρ j): then ρ Σ |d_j| ≈ ∫ |d(γ)| dγ is reported as well, the
    // reading of ||d||_1 for a continuous PI model (0: not reported).
    double spacing = 0.0;
};

struct RcAnalysis {
    double ts = 0.0;
    int period_samples = 0;    // N, the delay line's period analysed
    bool loop_stable = false;  // T (the loop without RC) stable
    double q_cutoff_Hz = 0.0;  // −3 dB of |Q| relative to |Q(1)| (Nyquist if never)
    // (3)
    double max_phase_deg = 0.0;  // max |θT + θ2| over (0, ω_c]
    double max_phase_at_Hz = 0.0;
    bool phase_ok = false;
    std::optional<double> phase_90_at_Hz;  // lowest f with |θ| = 90°; none: never below Nyquist
    // (2)
    double k_rc_max = 0.0;  // min over (0, ω_c] of 2 cos θ / A (<= 0 if |θ| >= 90° there)
    double k_rc_max_at_Hz = 0.0;
    bool gain_ok = false;
    // (1)
    double small_gain_peak = 0.0;
    double small_gain_at_Hz = 0.0;
    bool small_gain_ok = false;
    // exact
    std::optional<double> rc_max_abs_root;  // largest |z| of the roots of 1 − M
    std::optional<bool> rc_stable;
    // (15), (21): with hysteresis
    bool has_hysteresis = false;
    double g0 = 0.0;
    std::optional<double> gain_margin_rc;  // M_GL; none: no crossing (infinite)
    std::optional<double> gain_margin_rc_at_Hz;
    bool g0_ok = false;         // g0 <= M_GL
    bool g0_loop_stable = false;  // eigenvalues of the loop g0 L_rc
    double hinf_G2 = 0.0;       // ||G2||∞
    double hinf_G2_at_Hz = 0.0;
    std::string hinf_G2_method;  // "hamiltonian" or "grid"
    double density_l1 = 0.0;     // Σ |d_j| (the verdict uses this)
    double density_integral = 0.0;  // ρ Σ |d_j| if a spacing was given
    double density_bound = 0.0;  // 1 / (|g0| ||G2||∞)
    bool density_ok = false;     // (21)
    // Human-readable verdicts: every failing condition with its margin.
    std::vector<std::string> failures;
};

// From the closed loop T without RC (discrete Ss).
RcAnalysis analyze_rc_closed_loop(const Ss& t, const RcConfig& rc, const std::optional<PiHysteresis>& pi = {});
// From the loop gain L = Gc Gp (discrete Ss); T = L / (1 + L).
RcAnalysis analyze_rc_loop_gain(const Ss& l, const RcConfig& rc, const std::optional<PiHysteresis>& pi = {});

// Building blocks (exposed for tests).
// 1 + RC(z) as state space: the delay line (N − m1 states) and two copies of Q.
Ss rc_plus_one(const RcConfig& rc, double ts);
// M(z) = Q z^(m1−N) (1 − k_rc z^m2 T(z)).
Ss rc_characteristic(const Ss& t, const RcConfig& rc);
// RC(e^{jωTs}) evaluated directly.
cplx rc_response(const RcConfig& rc, double w_rad_s, double ts);

}  // namespace piezoloop::design
