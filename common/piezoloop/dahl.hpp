// Second-order Dahl hysteresis model (docs/models.md, 'Dahl model and
// feedforward'; Ahmad2020 §III-C/§IV-A) and its
// two uses: the inversion-free feedforward u_f = (x_r + H(x_r)) / ga, and the
// plant x = ga*v - H(x) for simulation. Float only.
//
// The model, driven by the displacement x:
//     dz/dx = A_H(s) z + B_H,     s = sgn(dx)
//     A_H(s) = [[0, 1], [-alpha2, -alpha1*s]],   B_H = [0, gamma_a]^T
//     H      = C_H(s) z,          C_H(s) = [beta2, beta1*s]
// dz is proportional to dx, so the model is rate independent and is
// integrated in the path variable, one sample increment dx at a time.
//
// Why the update below is stable for any step
// -------------------------------------------
// For fixed s the ODE is affine with the same equilibrium for both signs,
//     z_eq = -A_H(s)^-1 B_H = (gamma_a/alpha2, 0),
// so with e = z - z_eq a step of dx is e <- Phi(A_H(s)*dx) e. Writing
// dx = s*|dx|, the matrix that multiplies |dx| is M_s = s*A_H(s) =
// [[0, s], [-alpha2*s, -alpha1]]: trace -alpha1 <= 0, determinant alpha2 > 0,
// so both eigenvalues of A_H(s)*dx = M_s*|dx| have real part <= 0 for BOTH
// signs of dx (real part -alpha1*|dx|/2 when complex, both negative when
// real). Stronger, E(z) = alpha2*e1^2 + e2^2 is a common Lyapunov function:
// P = diag(alpha2, 1) gives M_s^T P + P M_s = diag(0, -2*alpha1) <= 0 for
// s = +1 and s = -1, i.e. dE/d|x| = -2*alpha1*e2^2. The exact solution can
// therefore never leave the ellipse E <= E(z0), whatever the path.
//
// The step used here is the trapezoidal rule (Crank-Nicolson), i.e. the
// Cayley transform R = (I - N/2)^-1 (I + N/2) of N = M_s*h. A Cayley
// transform of a P-dissipative matrix is P-contractive for every h > 0, so
// each sub-step keeps E non-increasing exactly like the exact flow: A-stable,
// and bounded with the exact solution's own bound, for any step size and for
// any sequence of signs. (I - N/2) has determinant 1 + alpha1*h/2 +
// alpha2*h^2/4 >= 1, so the division can never fail. No libm is involved:
// one division per sample plus multiplies (and a rare __builtin_sqrtf, below).
//
// Accuracy and rate independence: trapezoidal is second order; its phase error
// is (rho*h)^2/12 per radian and its amplitude error smaller, where
// rho = max(alpha1, sqrt(alpha2)) bounds the eigenvalue magnitude of M_s (the
// stiffness "per unit of x"). Each increment dx is split into 2^k equal
// sub-steps with rho*|dx|/2^k <= kDahlSubstepRho, the sub-step length chosen by
// PATH LENGTH, so the result for a monotone input does not depend on how it is
// sampled beyond that bound. The 2^k sub-steps are not executed one by one:
// R(h/2^k)^(2^k) is formed by k squarings of a 2x2 matrix (the product of 2^k
// identical steps, exactly, in exact arithmetic), so a huge increment costs
// O(k) and k <= kDahlMaxHalvings bounds the time per sample. If even 2^kmax
// sub-steps are longer than kDahlSubstepRho/rho the (less accurate) sub-step is
// backward Euler instead: also P-contractive, and L-stable, so a giant jump
// damps the transient as the exact solution does rather than leaving the
// undamped +-1 mode of the trapezoidal rule.
//
// Float details: the state is stored as the deviation from z_eq (in
// coordinates where E = |w|^2) and the step matrix as R - I, so neither a
// tiny transient on top of z_eq nor a tiny per-sample damping is lost to
// rounding (see DahlDeviation and DahlModel::advance). Rounding can still
// make a contraction factor exceed one by an ulp (it matters when alpha1 == 0,
// a lossless model, and 2^k squarings amplify it); after every update E is
// therefore clamped to its previous value. That only removes rounding-level
// growth, so E never grows over any number of samples; its price is a
// downward bias of at most ~eps per sample, and only when the physical decay
// per sample is below rounding (alpha1 ~ 0 with tiny steps).
//
// What this model can and cannot do (relevant to the published set,
// kAhmad2020Dahl): z_eq does not depend on s, so the loop of H against x
// comes from two sources only. (1) alpha1: the transient after a start or a
// reversal decays as e^(-alpha1*path/2); with alpha1 > 0 every loop shrinks
// to the line H = H_eq = beta2*gamma_a/alpha2, whatever the unit convention.
// (2) beta1: H jumps by -2*beta1*s_old*z2 at a reversal; z2 -> 0 with the
// transient, so this too is persistent only if alpha1 == 0 (then z is a
// function of x alone and the loop has width 2*|beta1*z2(x)|). Taken in µm
// the published set's transient lasts ~1 nm of path and H = 26.97 µm
// thereafter; tests/common/test_dahl.cpp shows the loops.
#pragma once

#include <limits>
#include <type_traits>

#include "piezoloop/status.hpp"

namespace piezoloop {

// Physical parameters. x, H in one length unit (µm in this project), v in V.
struct DahlParams {
    float alpha1;   // path damping, 1/x unit, >= 0
    float alpha2;   // path stiffness, 1/x^2 unit, > 0
    float beta1;    // output weight on z2 (times s)
    float beta2;    // output weight on z1
    float gamma_a;  // input gain B_H
    float ga;       // actuator gain, x unit per V, > 0
    bool operator==(const DahlParams&) const = default;
};

// Ahmad2020 published identification, as printed (units not stated there;
// see the note above and docs/models.md, 'Dahl model and feedforward').
inline constexpr DahlParams kAhmad2020Dahl{1.76e3f, 3.46e7f, 0.0f, 3.11e7f, 30.0f, 0.925f};

// Re-expresses a parameter set under a unit convention: the Dahl path variable
// is path_scale * x (e.g. 1e-6 to run a set identified in metres on µm), and H
// is output_scale times C_H z. Same model, rescaled state (z1 kept, z2 scaled
// by path_scale): alpha1*k, alpha2*k^2, gamma_a*k^2, beta2*c, beta1*c/k.
constexpr DahlParams dahl_params_in_units(const DahlParams& p, double path_scale,
                                          double output_scale) {
    const double k = path_scale, c = output_scale;
    return DahlParams{static_cast<float>(p.alpha1 * k), static_cast<float>(p.alpha2 * k * k),
                      static_cast<float>(p.beta1 * c / k), static_cast<float>(p.beta2 * c),
                      static_cast<float>(p.gamma_a * k * k), p.ga};
}

// Accuracy target of one sub-step: rho*|h| <= 1/64 gives a trapezoidal phase
// error of about 2e-5 per radian of the transient.
inline constexpr float kDahlSubstepRho = 1.0f / 64.0f;
// At most 2^20 sub-steps per sample (20 squarings): exact-to-target steps up
// to rho*|dx| = 16384, bounded time above that.
inline constexpr int kDahlMaxHalvings = 20;

namespace dahl_detail {
constexpr bool finite(float f) { return f - f == 0.0f; }
constexpr bool finite(double d) { return d - d == 0.0; }
constexpr float abs(float f) { return f < 0.0f ? -f : f; }
constexpr double dabs(double d) { return d < 0.0 ? -d : d; }
}  // namespace dahl_detail

// Checks a parameter set; names the first offending field and its range.
constexpr Status validate(const DahlParams& p) {
    using dahl_detail::dabs;
    using dahl_detail::finite;
    if (!finite(p.alpha1) || p.alpha1 < 0.0f) return error("alpha1", "must be finite and >= 0");
    if (!finite(p.alpha2) || !(p.alpha2 > 0.0f))
        return error("alpha2", "must be finite and > 0");
    if (!finite(p.beta1)) return error("beta1", "must be finite");
    if (!finite(p.beta2)) return error("beta2", "must be finite");
    if (!finite(p.gamma_a)) return error("gamma_a", "must be finite");
    if (!finite(p.ga) || !(p.ga >= 1e-30f) || !(p.ga <= 1e30f))
        return error("ga", "must be in [1e-30, 1e30] (x unit per V, > 0)");
    // Derived quantities the tick uses must be comfortably representable.
    const double a1 = p.alpha1, a2 = p.alpha2, b1 = p.beta1, b2 = p.beta2;
    if (!(a2 >= 1e-30) || !(a2 <= 1e30))
        return error("alpha2", "must be in [1e-30, 1e30] (sqrt(alpha2) and its inverse are used)");
    if (!(a1 <= 1e15)) return error("alpha1", "must be in [0, 1e15]");
    const double z_eq = p.gamma_a / a2;
    if (!(dabs(z_eq) <= 1e30) || !(dabs(b2 * z_eq) <= 1e30))
        return error("gamma_a", "gamma_a/alpha2 and beta2*gamma_a/alpha2 must be <= 1e30 in magnitude");
    if (!(b2 * b2 / a2 + b1 * b1 <= 1e36))
        return error("beta2", "beta2^2/alpha2 + beta1^2 must be <= 1e36");
    return ok_status();
}

// The model's state z.
struct DahlState {
    float z1 = 0.0f;
    float z2 = 0.0f;
};

// How the blocks store z: the deviation from the equilibrium in energy
// coordinates, w1 = sqrt(alpha2)*(z1 - z_eq), w2 = z2, so E = w1^2 + w2^2.
// Storing the deviation rather than z keeps full float precision in the
// transient however small it gets: z1 itself sits near z_eq (for the
// published set 26.97 µm worth of H) and a decay smaller than half an ulp of
// z1 per sample would be lost, a systematic drift over many small samples.
// The price is H's absolute rounding, a few eps of |H_eq| even where H is
// small (2e-6 µm for the published set).
struct DahlDeviation {
    float w1 = 0.0f;
    float w2 = 0.0f;
};

// Configuration of the model: coefficients derived once from DahlParams, and
// the pure functions of the state that the integrator, the feedforward and
// the plant share. No state of its own.
class DahlModel {
public:
    // Default: the pass-through model, H == 0 and ga == 1.
    constexpr DahlModel() { set(DahlParams{1.0f, 1.0f, 0.0f, 0.0f, 0.0f, 1.0f}); }

    // Rejected parameters leave the previous configuration in place.
    constexpr Status configure(const DahlParams& p) {
        const Status st = validate(p);
        if (st.ok()) set(p);
        return st;
    }
    constexpr const DahlParams& params() const { return p_; }
    constexpr float ga() const { return p_.ga; }
    constexpr float z_eq() const { return z_eq_; }
    constexpr float h_eq() const { return h_eq_; }  // beta2*gamma_a/alpha2

    constexpr DahlDeviation deviation(DahlState z) const {
        return DahlDeviation{omega_ * (z.z1 - z_eq_), z.z2};
    }
    constexpr DahlState state(DahlDeviation w) const {
        return DahlState{z_eq_ + w.w1 * inv_omega_, w.w2};
    }

    // H = C_H(s) z = H_eq + (beta2/sqrt(alpha2)) w1 + s*beta1 w2.
    constexpr float output(DahlDeviation w, int s) const {
        return h_eq_ + (c1_ * w.w1 + (s < 0 ? -p_.beta1 : p_.beta1) * w.w2);
    }
    // dH/dx when moving in direction s: C_H(s) (A_H(s) z + B_H)
    // = C_H(s) A_H(s) (z - z_eq) = beta2 w2 - s beta1 sqrt(alpha2) w1 - beta1 alpha1 w2.
    constexpr float slope(DahlDeviation w, int s) const {
        const float t = s < 0 ? -b1_omega_ * w.w1 : b1_omega_ * w.w1;
        return (p_.beta2 - b1_alpha1_) * w.w2 - t;
    }
    // The Lyapunov function alpha2*(z1 - z_eq)^2 + z2^2.
    constexpr float energy(DahlDeviation w) const { return w.w1 * w.w1 + w.w2 * w.w2; }
    constexpr float energy(DahlState z) const { return energy(deviation(z)); }
    // |H - H_eq| <= output_gain() * sqrt(energy) (Cauchy-Schwarz).
    constexpr float output_gain() const { return out_gain_; }

    // Deviation after the path increment dx (s = sgn(dx)); see the file
    // comment. The step matrix R is held as D = R - I: for the short steps of
    // a fast loop R is within 1e-5 of I and 1 + (tiny damping) would lose
    // most of the damping's digits in float; D keeps them, and
    // w + D w rounds only once at the end.
    constexpr DahlDeviation advance(DahlDeviation w, float dx) const {
        if (dx == 0.0f || !(dx == dx)) return w;
        const float e_old = energy(w);

        // Sub-step count 2^k by path length: rho*|dx|/2^k <= kDahlSubstepRho.
        float q = dahl_detail::abs(dx) * rho_over_target_;  // +inf for absurd dx: k = max
        int k = 0;
        float h = dx;
        while (q > 1.0f && k < kDahlMaxHalvings) {
            q *= 0.5f;
            h *= 0.5f;  // exact: a power of two, and h stays far above the subnormals
            ++k;
        }
        // D = [[P, c], [-c, Q]]; products of such matrices keep the shape.
        float P, c, Q;
        const float ah = dahl_detail::abs(h);
        if (!(rho_ * ah <= 1e15f)) {
            // Beyond any accuracy (and before b^2 could overflow): the
            // L-stable limit R = 0 of backward Euler. Needs |dx| > 1e21/rho.
            P = -1.0f;
            Q = -1.0f;
            c = 0.0f;
        } else if (q <= 1.0f) {
            // Trapezoidal, b = omega*h/2 (signed), m = alpha1*|h|/2:
            // R = [[1+m-b^2, 2b], [-2b, 1-m-b^2]] / (1+m+b^2), so
            // D = [[-2b^2, 2b], [-2b, -2m-2b^2]] / (1+m+b^2).
            const float b = 0.5f * omega_ * h;
            const float m = 0.5f * p_.alpha1 * ah;
            const float bb = b * b;
            const float inv_d = 1.0f / (1.0f + m + bb);
            P = -2.0f * bb * inv_d;
            c = 2.0f * b * inv_d;
            Q = -2.0f * (m + bb) * inv_d;
        } else {
            // Backward Euler, b = omega*h, m = alpha1*|h|:
            // R = (I - hM)^-1 = [[1+m, b], [-b, 1]] / (1+m+b^2).
            const float b = omega_ * h;
            const float m = p_.alpha1 * ah;
            const float bb = b * b;
            const float inv_d = 1.0f / (1.0f + m + bb);
            P = -bb * inv_d;
            c = b * inv_d;
            Q = -(m + bb) * inv_d;
        }
        // R <- R^2 as D <- 2D + D^2: 2^k sub-steps in k products.
        for (int i = 0; i < k; ++i) {
            const float cc = c * c;
            const float P2 = 2.0f * P + (P * P - cc);
            const float Q2 = 2.0f * Q + (Q * Q - cc);
            c = c * (2.0f + (P + Q));
            P = P2;
            Q = Q2;
        }
        DahlDeviation n{w.w1 + (P * w.w1 + c * w.w2), w.w2 + (Q * w.w2 - c * w.w1)};
        // Clamp rounding-level growth of E (see file comment).
        const float e_new = energy(n);
        if (e_new > e_old) {
            const float f = e_old > 0.0f ? __builtin_sqrtf(e_old / e_new) : 0.0f;
            n.w1 *= f;
            n.w2 *= f;
        }
        return n;
    }

private:
    constexpr void set(const DahlParams& p) {
        p_ = p;
        const double a2 = p.alpha2;
        const double zeq = p.gamma_a / a2;
        z_eq_ = static_cast<float>(zeq);
        h_eq_ = static_cast<float>(zeq * p.beta2);
        omega_ = sqrt_constexpr(p.alpha2);
        inv_omega_ = static_cast<float>(1.0 / static_cast<double>(omega_));
        c1_ = static_cast<float>(static_cast<double>(p.beta2) / static_cast<double>(omega_));
        b1_omega_ = p.beta1 * omega_;
        b1_alpha1_ = p.beta1 * p.alpha1;
        rho_ = p.alpha1 > omega_ ? p.alpha1 : omega_;
        rho_over_target_ = rho_ / kDahlSubstepRho;
        const double g2 = static_cast<double>(p.beta2) * p.beta2 / a2 +
                          static_cast<double>(p.beta1) * p.beta1;
        out_gain_ = sqrt_constexpr(static_cast<float>(g2));
    }
    // IEEE sqrt at run time (correctly rounded everywhere); Newton in double
    // when constant-evaluated.
    static constexpr float sqrt_constexpr(float v) {
        if (std::is_constant_evaluated()) {
            if (!(v > 0.0f)) return 0.0f;
            double g = v > 1.0f ? static_cast<double>(v) : 1.0;
            for (int i = 0; i < 200; ++i) g = 0.5 * (g + static_cast<double>(v) / g);
            return static_cast<float>(g);
        }
        return __builtin_sqrtf(v);
    }

    DahlParams p_{};
    float z_eq_ = 0.0f;
    float h_eq_ = 0.0f;
    float omega_ = 1.0f;
    float inv_omega_ = 1.0f;
    float c1_ = 0.0f;
    float b1_omega_ = 0.0f;
    float b1_alpha1_ = 0.0f;
    float rho_ = 1.0f;
    float rho_over_target_ = 1.0f;
    float out_gain_ = 0.0f;
};

namespace dahl_detail {
// Deviation of z under model m, or the equilibrium if z is not finite or too
// far out for E to be a float (keeps every later step finite).
constexpr DahlDeviation checked_deviation(const DahlModel& m, DahlState z) {
    const DahlDeviation w = m.deviation(z);
    return finite(m.energy(w)) ? w : DahlDeviation{};
}
}  // namespace dahl_detail

// The Dahl integrator: model + state (z, the previous input, the direction).
class DahlIntegrator {
public:
    // The state carries on: z is kept (re-expressed for the new equilibrium).
    constexpr Status configure(const DahlParams& p) {
        const DahlState z = model_.state(w_);
        const Status st = model_.configure(p);
        if (st.ok()) w_ = dahl_detail::checked_deviation(model_, z);
        return st;
    }
    constexpr const DahlModel& model() const { return model_; }

    // Virgin state z = 0 at input x0, direction +.
    constexpr void reset(float x0) { reset(x0, DahlState{}, 1); }
    constexpr void reset(float x0, DahlState z, int s) {
        x_prev_ = dahl_detail::finite(x0) ? x0 : 0.0f;
        w_ = dahl_detail::checked_deviation(model_, z);
        s_ = s < 0 ? -1 : 1;
    }

    // Advances by dx = x - x_prev and returns H = C_H(s) z. A non-finite x is
    // ignored (the state holds); an increment that overflows is taken as a
    // jump of infinite length, after which the damped transient is gone.
    constexpr float step(float x) {
        if (!dahl_detail::finite(x)) return output();
        const float dx = x - x_prev_;
        if (dx != 0.0f) {
            w_ = dahl_detail::finite(dx) ? model_.advance(w_, dx) : DahlDeviation{};
            s_ = dx < 0.0f ? -1 : 1;
            x_prev_ = x;
        }
        return output();
    }

    constexpr float output() const { return model_.output(w_, s_); }
    constexpr DahlState state() const { return model_.state(w_); }
    constexpr DahlDeviation deviation() const { return w_; }
    constexpr int direction() const { return s_; }
    constexpr float last_input() const { return x_prev_; }

private:
    DahlModel model_{};
    DahlDeviation w_{};
    float x_prev_ = 0.0f;
    int s_ = 1;
};

// Inversion-free feedforward (Ahmad2020 eq. 14): u_f = (x_r + H(x_r)) / ga,
// with H from a Dahl integrator run on the desired displacement x_r.
class DahlFeedforward {
public:
    constexpr Status configure(const DahlParams& p) { return integ_.configure(p); }
    constexpr void reset(float x_r0_um) { integ_.reset(x_r0_um); }
    constexpr void reset(float x_r0_um, DahlState z, int s) { integ_.reset(x_r0_um, z, s); }
    // Desired displacement in, command voltage out. A non-finite x_r holds
    // the previous one.
    constexpr float step(float x_r_um) {
        if (!dahl_detail::finite(x_r_um)) x_r_um = integ_.last_input();
        const float h = integ_.step(x_r_um);
        return (x_r_um + h) / integ_.model().ga();
    }
    constexpr const DahlIntegrator& integrator() const { return integ_; }

private:
    DahlIntegrator integ_{};
};

// Limits of the plant solver.
inline constexpr int kDahlActuatorMaxIterations = 48;
// Newton is used only while the loading slope 1 + dH/dx exceeds this; below it
// (near a fold of x + H(x)) the bracket is bisected instead.
inline constexpr float kDahlMinLoadingSlope = 1e-6f;

// The plant x = ga*v - H(x). Per sample it solves g(x) = x + H(x) = ga*v
// along the path from the previous x, with the model advanced from the state
// at the start of the sample for every trial increment (so no trial ever
// moves the committed state):
//   - direction: s = sgn(ga*v - g(x_prev)). g increases with x when the
//     loading slope 1 + C_H(A_H z + B_H) is positive, so then sgn(dx) =
//     sgn(residual) = sgn(dv) in steady motion.
//   - the increment d >= 0 along s solves phi(d) = d + s*(H(z(s*d)) - H0) -
//     |residual| = 0 by safeguarded Newton (Newton step d -= phi / (1 + dH/dx),
//     i.e. the increment dx = ga*dv / (1 + C_H(A_H z + B_H)), iterated) inside a
//     bracket [lo, hi]: lo = 0 (phi < 0) and hi = |residual| + 2*K*sqrt(E(z)),
//     where phi(hi) >= 0 because |H - H_eq| <= K*sqrt(E) and E cannot grow
//     along the path. Non-positive slope or a Newton step outside the bracket
//     -> bisection. So it converges even through a fold (x then jumps to a
//     root further along the path, as the physical plant would).
//   - tolerance |phi| <= 4 float eps * (|ga v| + |x| + |H_eq| + K*sqrt(E)),
//     the rounding level of g itself.
//   - at most kDahlActuatorMaxIterations trials, each one bounded advance().
//     If not converged the undershooting end lo is taken, so the residual
//     keeps its sign and the next sample continues in the same direction
//     (an overshoot would fake a reversal, which changes a hysteretic state).
//   - with beta1 != 0, H jumps by -2*beta1*s_old*z2 at a reversal; if the
//     target lies inside that jump the plant sticks (x holds, s unchanged).
class DahlActuator {
public:
    // The state carries on (as for DahlIntegrator).
    constexpr Status configure(const DahlParams& p) {
        const DahlState z = model_.state(w_);
        const Status st = model_.configure(p);
        if (st.ok()) w_ = dahl_detail::checked_deviation(model_, z);
        return st;
    }
    constexpr const DahlModel& model() const { return model_; }

    // Virgin state z = 0 at voltage v0, so x = ga*v0.
    constexpr void reset(float v0_V) {
        w_ = dahl_detail::checked_deviation(model_, DahlState{});
        s_ = 1;
        x_ = dahl_detail::finite(v0_V) ? model_.ga() * v0_V : 0.0f;
    }
    // Explicit state; x should satisfy x + H = ga*v for the next voltage.
    constexpr void reset_state(float x_um, DahlState z, int s) {
        x_ = dahl_detail::finite(x_um) ? x_um : 0.0f;
        w_ = dahl_detail::checked_deviation(model_, z);
        s_ = s < 0 ? -1 : 1;
    }

    // Voltage on the piezo in, displacement out.
    constexpr float step(float v_V) {
        if (!dahl_detail::finite(v_V)) return x_;
        const float target = model_.ga() * v_V;
        float h0 = model_.output(w_, s_);
        float res = target - (x_ + h0);
        // H = H_eq + (deviation term, at most `spread`) carries an absolute
        // rounding of a few eps * (|H_eq| + spread) even when H itself is
        // small: the tolerance is that rounding level of g = x + H.
        const float spread = model_.output_gain() * __builtin_sqrtf(model_.energy(w_));
        const float scale = dahl_detail::abs(target) + dahl_detail::abs(x_) +
                            dahl_detail::abs(model_.h_eq()) + spread;
        const float tol = 4.0f * std::numeric_limits<float>::epsilon() * scale +
                          std::numeric_limits<float>::min();
        if (!(dahl_detail::abs(res) > tol)) return x_;
        const int s = res > 0.0f ? 1 : -1;
        if (s != s_) {
            h0 = model_.output(w_, s);  // C_H(s) z for the new direction
            res = target - (x_ + h0);
            if (!(res * static_cast<float>(s) > tol)) return x_;  // inside the jump: stick
        }
        const float sf = static_cast<float>(s);
        const float need = dahl_detail::abs(res);

        float lo = 0.0f;
        DahlDeviation w_lo = w_;
        float hi = need + 2.0f * spread;
        hi = hi + hi * 1e-3f + tol;
        if (!dahl_detail::finite(hi)) hi = std::numeric_limits<float>::max();
        const float den0 = 1.0f + model_.slope(w_, s);
        float d = den0 > kDahlMinLoadingSlope ? need / den0 : 0.5f * hi;

        float acc = lo;
        DahlDeviation w_acc = w_lo;
        for (int it = 0; it < kDahlActuatorMaxIterations; ++it) {
            if (!(d > lo && d < hi)) d = lo + 0.5f * (hi - lo);
            if (!(d > lo && d < hi)) break;  // bracket exhausted in float
            const DahlDeviation wt = model_.advance(w_, sf * d);
            const float phi = d + sf * (model_.output(wt, s) - h0) - need;
            if (dahl_detail::abs(phi) <= tol) {
                acc = d;
                w_acc = wt;
                break;
            }
            if (phi < 0.0f) {
                lo = d;
                w_lo = wt;
            } else {
                hi = d;
            }
            acc = lo;
            w_acc = w_lo;
            const float den = 1.0f + model_.slope(wt, s);
            d = den > kDahlMinLoadingSlope ? d - phi / den : lo + 0.5f * (hi - lo);
        }
        if (acc > 0.0f) {
            x_ += sf * acc;
            w_ = w_acc;
            s_ = s;
        }
        return x_;
    }

    constexpr float position() const { return x_; }
    constexpr float output() const { return model_.output(w_, s_); }
    constexpr DahlState state() const { return model_.state(w_); }
    constexpr DahlDeviation deviation() const { return w_; }
    constexpr int direction() const { return s_; }

private:
    DahlModel model_{};
    DahlDeviation w_{};
    float x_ = 0.0f;
    int s_ = 1;
};

}  // namespace piezoloop
