// Frequency-domain loop figures of a SISO model: gain and phase margins (all
// crossings), the −3 dB bandwidth, and the unwrapped phase at a frequency.
//
// Method: the model is sampled on an analysis grid (log-spaced, 200 points
// per decade, plus 121 points across every lightly damped pole or zero,
// ω_n (1 + k ζ / 10), |k| <= 60), so that two crossings can only hide between
// neighbouring samples if they are closer than a tenth of the local
// resonance width. Each bracketed crossing is then refined by bisection to
// 1e-12 relative in ω: |L| = 1 on log|L|, phase = (2k+1)·180° on the
// unwrapped phase. The phase is unwrapped along the grid starting from the
// principal value at the lowest frequency; it is continuous in ω, so the
// values between samples come from the branch nearest the interpolation.
//
// Conventions (negative feedback u = −L y):
//   gain margin at a phase crossover ω_pc: GM = 1 / |L(jω_pc)| (> 1 means
//   the gain can grow by that factor, < 1 that it can shrink), in dB
//   20 log10 GM; the reported margin is the crossing with the smallest |dB|.
//   phase margin at a gain crossover ω_gc: PM = 180° + ∠L(jω_gc) wrapped to
//   (−180°, 180°]; the reported margin is the crossing with the smallest PM.
// ω in rad/s everywhere; discrete models are evaluated at e^{jω ts} up to
// the Nyquist frequency π/ts (a real negative L at ω = 0 or at Nyquist counts
// as a phase crossover).
#pragma once

#include <optional>
#include <vector>

#include "analysis/hinf.hpp"
#include "lti/lti.hpp"

namespace piezoloop::design {

// A model sampled on a grid, with its phase unwrapped along the grid from
// the principal value at the first point. Points where the response is zero
// or not finite are left out.
struct FrequencySamples {
    std::vector<double> w;      // rad/s
    std::vector<cplx> h;
    std::vector<double> phase;  // rad, unwrapped
};
FrequencySamples sample_response(const SsEvaluator& model, const std::vector<double>& grid);
// Phase of the model at w (rad) on the branch nearest `guess`.
double phase_near(const SsEvaluator& model, double w_rad_s, double guess_rad);

// Grid (rad/s, ascending) for a model whose poles and zeros are `critical`
// (s-plane if ts == 0, z-plane otherwise). Continuous: from 1e-2 of the
// smallest non-zero |critical| to 1e2 of the largest (1e-2 … 1e2 rad/s if
// none); discrete: the same lower end up to π/ts, both ends included.
// Extra points (e.g. a frequency of interest) may be merged in.
std::vector<double> analysis_grid(const std::vector<cplx>& critical, double ts,
                                  const std::vector<double>& extra_w = {});

struct PhaseCrossover {  // ∠L = (2k+1)·180°
    double w_rad_s = 0.0;
    double gain_margin = 0.0;  // 1 / |L|
    double gain_margin_db = 0.0;
};
struct GainCrossover {  // |L| = 1
    double w_rad_s = 0.0;
    double phase_margin_deg = 0.0;
};

struct Margins {
    std::vector<PhaseCrossover> phase_crossovers;  // ascending ω
    std::vector<GainCrossover> gain_crossovers;    // ascending ω
    std::optional<PhaseCrossover> gain_margin;     // smallest |dB|; none: infinite
    std::optional<GainCrossover> phase_margin;     // smallest PM; none: |L| never 1
};

// Margins of the loop transfer L (poles and zeros of L as `critical`, used
// for the grid; they need not be exact).
Margins loop_margins(const Ss& loop, const std::vector<cplx>& critical);

// Closed-loop −3 dB bandwidth: the lowest ω where |T| falls below |T(0)|/√2
// (|T(0)|: the gain at s = 0 or z = 1). None if |T| never falls below it on
// the grid (or T(0) is 0 or infinite).
std::optional<double> bandwidth_rad_s(const Ss& closed_loop, const std::vector<cplx>& critical);

// Phase (degrees) unwrapped along the analysis grid from its lowest
// frequency up to w_rad_s.
double unwrapped_phase_deg(const Ss& model, const std::vector<cplx>& critical, double w_rad_s);

}  // namespace piezoloop::design
