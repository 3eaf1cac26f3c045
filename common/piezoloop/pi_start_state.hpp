// The play states a PI compensator starts from when its loop arms, so that
// its first output is the command already in effect (bumpless arming).
//
// A PI compensator that starts from zero states outputs, for the stage's
// reading x, its virgin-curve value P^-1(x). The stage at rest got to x by
// some history of commands (a triangle's way down, a disarm's ramp to 0 V)
// and sits there at another command u. Arming from zero states steps the
// command from u to P^-1(x): a jump that rings a lightly damped mode.
//
// The states chosen instead are those of the operator after it came up to a
// turning point t from far below and then went to x (t >= x):
//
//   w_j = min(f + r_j, t - r_j),   f = the input map of x,
//
// a history every play operator can have (|f - w_j| <= r_j), running from
// the ascending major branch (t = f) to the descending one (t >= f + 2 r_max).
// The output G(t) = p0 f + sum_j p_j w_j is piecewise linear in t with
// breakpoints f + 2 r_j; t is where G crosses u on the first segment that
// brackets it, or the breakpoint nearest u when none does (u outside the
// loop the model can reach at x: the feedback takes the rest).
//
// Runs in double in the main loop, from the model; the tick only writes the
// states (PiOperator::start_ascended_to) on the arming tick.
#pragma once

#include "piezoloop/pi_model.hpp"

namespace piezoloop {

struct PiStartState {
    bool preset = false;  // false: start from zero states (they already give u, or do better)
    double turn = 0.0;    // t, in the play domain (units of the input map's output f)
};

namespace pi_start_detail {

// The output from zero states at f (the virgin curve).
inline double output_from_rest(const PiModel& m, double f) {
    double y = static_cast<double>(m.p0) * f;
    for (int j = 0; j < m.count; ++j) {
        const double r = m.thresholds[static_cast<unsigned>(j)];
        const double w = f - r > 0.0 ? f - r : (f + r < 0.0 ? f + r : 0.0);
        y += static_cast<double>(m.weights[static_cast<unsigned>(j)]) * w;
    }
    return y;
}

inline double magnitude(double v) { return v < 0.0 ? -v : v; }

}  // namespace pi_start_detail

// The start state for input x (physical units of the model's input) and the
// command in effect u (units of its output). Zero states are kept when their
// output is within `tolerance` of u, so a loop armed where its model starts
// (a stage at rest at zero) arms exactly as it always has.
//
// O(N), in one pass over the breakpoints (the main loop of a Cortex-M3
// computes it in software double, with the tick masked when several axes arm
// together): on [f + 2 r_(k-1), f + 2 r_k] the operators below k are capped
// at f + r_j and the others follow t, so
//   G(t) = p0 f + sum_(j<k) p_j (f + r_j) + t sum_(j>=k) p_j - sum_(j>=k) p_j r_j.
inline PiStartState pi_start_for_output(const PiModel& m, float x, double u, double tolerance) {
    using namespace pi_start_detail;
    const double f = static_cast<double>(m.input_gain * dead_zone_map(m, x) + m.input_offset);
    const double miss_from_rest = magnitude(output_from_rest(m, f) - u);
    if (miss_from_rest <= tolerance) return {};

    double capped = static_cast<double>(m.p0) * f;  // p0 f + the capped operators' terms
    double slope = 0.0, offset = 0.0;                 // sum_(j>=k) p_j and sum_(j>=k) p_j r_j
    for (int j = 0; j < m.count; ++j) {
        const double p = m.weights[static_cast<unsigned>(j)];
        slope += p;
        offset += p * static_cast<double>(m.thresholds[static_cast<unsigned>(j)]);
    }
    double t_prev = f;
    double g_prev = capped + f * slope - offset;  // the ascending major branch
    double best_t = t_prev, best_miss = magnitude(g_prev - u);
    for (int k = 0; k < m.count; ++k) {
        const double p = m.weights[static_cast<unsigned>(k)];
        const double r = m.thresholds[static_cast<unsigned>(k)];
        const double t = f + 2.0 * r;
        const double g = capped + t * slope - offset;
        if (t > t_prev && (g_prev - u) * (g - u) <= 0.0) {
            // G is linear between the breakpoints: its crossing of u, exact.
            if (g == g_prev) return {true, t_prev};
            return {true, t_prev + (u - g_prev) / (g - g_prev) * (t - t_prev)};
        }
        if (magnitude(g - u) < best_miss) {
            best_miss = magnitude(g - u);
            best_t = t;
        }
        // Operator k is capped from here on.
        capped += p * (f + r);
        slope -= p;
        offset -= p * r;
        t_prev = t;
        g_prev = g;
    }
    if (best_miss >= miss_from_rest) return {};
    return {true, best_t};
}

}  // namespace piezoloop
