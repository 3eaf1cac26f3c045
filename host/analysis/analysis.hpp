// Loop analysis of a plant P and a controller K (docs/models.md, 'Metrics'): the four
// closed-loop maps as state-space models, their H∞ norms, closed-loop poles
// and stability, gain and phase margins, the −3 dB bandwidth of T and the
// phase lag of T at given frequencies.
//
// Interconnection (negative unity feedback, all SISO):
//     e = r − y,   u = K e + d,   y = P u
//     S  = r → e = 1 / (1 + PK)        T  = r → y = PK / (1 + PK)
//     KS = r → u = K / (1 + PK)        GS = d → y = P / (1 + PK)
// The four share one closed-loop state matrix built from the states of K and
// P (no cancellation, so an unstable hidden mode shows up in the poles: this
// is internal stability). Well-posedness needs 1 + D_P D_K != 0.
// Both models must be continuous, or discrete with the same ts.
#pragma once

#include <optional>
#include <vector>

#include "analysis/hinf.hpp"
#include "lti/lti.hpp"
#include "analysis/margins.hpp"

namespace piezoloop::design {

struct FeedbackLoop {
    Ss S, T, KS, GS;
};

FeedbackLoop feedback_loop(const Ss& plant, const Ss& controller);

struct LoopAnalysisOptions {
    std::vector<double> phase_lag_at_Hz;  // frequencies at which to report T's phase lag
    double rel_tol = 1e-7;                // H∞ accuracy (see hinf.hpp)
};

struct PhaseLag {
    double f_Hz = 0.0;
    double lag_deg = 0.0;       // −∠T, unwrapped from low frequency
    double magnitude_db = 0.0;  // |T| there
};

struct LoopAnalysis {
    double ts = 0.0;
    bool stable = false;
    // Continuous: max real part of the closed-loop poles (rad/s);
    // discrete: max |z|.
    double stability_measure = 0.0;
    std::vector<cplx> closed_loop_poles;
    HinfResult hinf_S, hinf_T, hinf_KS, hinf_GS;
    Margins margins;  // of L = P K
    std::optional<double> bandwidth_Hz;  // −3 dB of T relative to |T(0)|
    std::vector<PhaseLag> phase_lags;
};

LoopAnalysis analyze_loop(const Zpk& plant, const Zpk& controller, const LoopAnalysisOptions& options = {});

// ||W · M||∞ for a weight W and a closed-loop map M (same ts).
HinfResult weighted_hinf(const Zpk& weight, const Ss& closed_loop_map, double rel_tol = 1e-7);

// Poles and zeros of the loop and of the closed loop, for analysis grids.
std::vector<cplx> critical_points(const Zpk& plant, const Zpk& controller);

}  // namespace piezoloop::design
