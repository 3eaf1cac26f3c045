// Commissioning a stage the tool has not seen (docs/commissioning.md): from
// measurements alone to a checked, verified controller, on a board
// (link/board_stage) or the simulator (commission/sim_stage), through the
// same steps (commission/stage_access.hpp):
//
//   1. safety: open-loop command steps of 2, 5 and 10 % of the command span
//      from mid-span; each must move the stage (|Δy| above 5x the noise),
//      off the sensor's rails (ten samples at one extreme value at or beyond
//      the range the sensor reads), with the gain of the previous step within
//      ±50 % (same sign).
//   2. hysteresis and travel: an open-loop loop over the whole command span
//      (the large signal), 5 Hz, two smooth (1 - cos) cycles; its measured
//      cycle's extremes within what the sensor reads are the reach, which
//      the range must fit with kReachMargin free at each end, and whose
//      middle centres every triangle after. A PI model with an output offset
//      is fitted to the second cycle (the first runs the plays: the jump to
//      its base rings the stage's modes; ident/pi_fit, 8 operators,
//      monotone so that it has an analytic inverse). A loop that reaches a
//      rail or trips is repeated about mid-span at 0.7x for the fit.
//   3. frequency response: open loop about mid-span, 5 % of the span, at
//      most 1000 lines.
//   4. model: continuous fits of order 2, 4, 6, 8 (zeros two fewer: a stage
//      rolls off beyond the band; one tick of delay taken out); the lowest
//      whose RMS relative error on the lines with SNR >= 20 dB is below
//      10 % (the hysteresis bends a stage's response by several %), else the
//      best. The identified stage (commission/identified_stage) is the PI
//      hysteresis and its offset followed by the dynamics (without a PI
//      fit: the largest safety step's static gain).
//   5. candidates on the fitted model normalised to unit DC gain: robust,
//      mixed-sensitivity H∞ (plant reduced to 6 states if larger, W1 =
//      (s/1.6 + ω_b)/(s + 1e-3 ω_b) at the target bandwidth, W2 = 0.5; again
//      at 0.7x and 0.5x the target when refused), the same with the fit's
//      error on the measured lines as the uncertainty weight W3 on T
//      (commission/uncertainty_weight), classic, PI + notches
//      (synth/pi_notch) at the target bandwidth, and, when the fit has a
//      lightly damped mode (ζ < 0.2), robust damped: the same weights with a
//      disturbance at the plant's input (synth/damping_mixsyn), which damps
//      the mode instead of cancelling it (listed last: chosen only when its
//      prediction is better by more than the tie).
//   6. each checked on the measured response (analysis/measured_loop):
//      PM >= 45°, GM >= 6 dB, max|S| <= 2, |L| <= 0.5 at the band's top; a candidate that fails is never
//      loaded. When none passes at the automatic target bandwidth, it is
//      halved (twice at most).
//   7. each passing candidate's tracking of a 10 Hz triangle over half the
//      range is predicted on the identified stage (each from the same state
//      at rest), alone, with the PI model's inverse as feedforward on the
//      reference, and with that and a reference pre-filter (a notch at each
//      lightly damped mode of the fit in the measured band, ζ < 0.2, the two
//      lowest); with strong hysteresis (kStrongHysteresisSpread) also with
//      the inverse in series after the feedback, which are first designed
//      on the stage as measured through the inverse (ThroughInverse): the
//      first passing one closes the loop on the stage, the closed loop's
//      response gives the stage's gain through the inverse, and each series
//      candidate is divided by it and checked again. The lowest e_max is
//      chosen (within kPredictionTie, the one listed first).
//   8. verification on the stage: the chosen controller loaded, a triangle
//      over half the range at 10 Hz (the check), the closed loop's frequency
//      response (d at the command, 2 % of the span; its T gives the achieved
//      bandwidth), then triangles over the whole range at 1 Hz, 10 Hz and a
//      tenth of the achieved bandwidth, each beside its prediction, which
//      runs the same sequence on the identified stage (both carry on from
//      run to run, as a board's stage does). A run worse than twice its
//      prediction plus 2 % of its range, or one that trips, fails the
//      verification, with the reason the record shows
//      (commission/tracking_diagnosis): the loop does not behave as
//      designed, and is not kept.
#pragma once

#include <functional>
#include <optional>
#include <string>
#include <vector>

#include <nlohmann/json.hpp>

#include "analysis/measured_loop.hpp"
#include "commission/identified_stage.hpp"
#include "commission/stage_access.hpp"
#include "commission/fastest_triangle.hpp"
#include "commission/uncertainty_weight.hpp"
#include "lti/lti.hpp"
#include "measure/frf_plan.hpp"
#include "measure/step_loops_plan.hpp"
#include "ident/pi_fit.hpp"
#include "measure/tf_fit.hpp"

namespace piezoloop::commission {

// A loading curve whose slope grows by more than this over the loop is
// strong hysteresis (Shan2012's stage: about 4.5): a loop designed on the
// small-signal slope sees several times its gain at large amplitudes, so the
// candidates are also realised with the fitted inverse in series, which
// linearises the stage at every amplitude.
inline constexpr double kStrongHysteresisSpread = 2.0;

// A candidate's loop gain on the measured band's top lines must stay below
// this (6 dB short of a crossover, as the gain margin asks): beyond the band
// nothing is measured, so a loop still near 1 at its edge is refused.
inline constexpr double kMaxLoopGainAtBandEdge = 0.5;

// The triangles stay this fraction of the measured reach inside each of its
// ends (the loop's corners and the controller's overshoot need room).
inline constexpr double kReachMargin = 0.02;

// Predictions within this fraction of the best one are a tie, which the
// candidate listed first wins (commission.cpp, step 7).
inline constexpr double kPredictionTie = 0.05;

struct CommissionRequest {
    double range_um = 0.0;             // the travel the loop must hold
    double target_bandwidth_Hz = 0.0;  // 0: a third of the first lightly damped mode, at most rate / 20; an eighth of the measured band without one
};

struct SafetyStep {
    double step_V = 0.0, from_V = 0.0;
    double y_before_um = 0.0;  // at rest before the step
    double dy_um = 0.0, noise_um = 0.0, gain_um_per_V = 0.0;
};

struct ModelFit {
    int poles = 0, zeros = 0;
    double rms_rel = 0.0;               // |G_fit - G| / |G|, RMS over the lines with SNR >= 20 dB
    design::Zpk model;                  // continuous, u (V) -> y (µm), delay left out
    double dc_gain_um_per_V = 0.0;
};

struct Candidate {
    std::string name;          // robust | classic, "+ PI inverse", "+ pre-filter"
    std::string method;        // how it was made
    design::Zpk controller;    // continuous, e (µm) -> u (V)
    std::optional<PiModel> feedforward;     // r (µm) -> u (V)
    std::optional<design::Zpk> prefilter;   // r (µm) -> r (µm), continuous
    bool series = false;       // the inverse in series after the feedback (controller e -> µm)
    Controller loaded() const { return {controller, feedforward, prefilter, series}; }
    int order = 0;
    double design_crossover_Hz = 0.0;
    design::MeasuredLoop measured;  // on the measured lines
    bool passes = false;
    std::string refusal;       // why it fails the checks or could not be made
    std::optional<TrackingRun> predicted;  // 10 Hz triangle over half the range, on the identified stage
};

// One verification triangle on the stage beside its prediction.
struct Verification {
    TrackRequest request;
    TrackingRun predicted, measured;
};

// The stage as the loop sees it through the inverse in series (strong
// hysteresis; commission.cpp, step 6b). The core runs the inverse in series
// only after a feedback, so the response through it is measured in closed
// loop, with the first passing series candidate (the probe) closing it:
// with d at the command, S = U / D and L = 1/S - 1 = G P^-1' K, where G =
// Y / U is the same run's plant and P^-1' the inverse's gain as the loop
// drives it. gain = L / (G K) times the open-loop fit's DC gain is the
// linearised stage over the unit-gain model the candidates were designed
// on: 1 when the fitted inverse undoes the stage's slope exactly.
struct ThroughInverse {
    std::string probe;                            // the candidate that closed the loop
    TrackingRun probe_measured, probe_predicted;  // its check triangle (loads it), on the stage and predicted
    measure::FrfRequest request;
    std::optional<measure::FrfRun> frf;           // the closed loop through the inverse
    double probe_max_sensitivity = 0.0, probe_max_sensitivity_Hz = 0.0;  // max |S| measured (SNR >= 20 dB)
    std::vector<double> f_Hz;                     // the lines used: SNR >= 20 dB and 0.2 <= |L| <= 5
    std::vector<design::cplx> gain;               // on those lines
    double gain_magnitude = 1.0, gain_phase_deg = 0.0;  // their medians
    std::string note;                             // what was done, or why nothing was
    // Each series candidate's loop on the lines through the inverse as it
    // was designed (on the unit-gain model), before its gain is divided by
    // gain_magnitude; the candidate's `measured` is after.
    std::vector<std::pair<std::string, design::MeasuredLoop>> before;
};

struct Commissioning {
    std::vector<SafetyStep> safety;
    double gain_um_per_V = 0.0;
    measure::FrfRun frf;
    measure::FrfRequest frf_request;
    measure::LoopsRequest loops_request;
    measure::LoopsRun loops;
    std::optional<design::PiFitResult> hysteresis;  // the PI fit; absent when it failed
    std::string hysteresis_note;                    // the fit's figures, or why it failed
    // The travel, from the hysteresis loop's measured cycle (the large
    // signal): what the loop moved the stage over, within the sensor's range.
    double reach_min_um = 0.0, reach_max_um = 0.0;
    double loop_span_V = 0.0;                 // the loop's command span
    double large_signal_gain_um_per_V = 0.0;  // reach over the loop's span
    // The fitted loading curve's slope spread (last / first slope): above
    // kStrongHysteresisSpread the inverse is also put in series.
    double slope_spread = 0.0;
    std::vector<ModelFit> fits;  // every order tried
    std::optional<UncertaintyWeight> uncertainty;  // from the chosen fit's error on the measured lines
    int chosen_fit = -1;
    double target_bandwidth_Hz = 0.0;
    double centre_um = 0.0;      // the displacement at mid-span: every triangle's centre
    IdentifiedStage identified;
    std::optional<ThroughInverse> through_inverse;  // strong hysteresis with a passing series candidate
    std::vector<Candidate> candidates;
    int chosen = -1;             // index into candidates; -1: none passes
    double bandwidth_Hz = 0.0;   // the chosen loop's: |T| = |L / (1 + L)| falls below -3 dB on the open-loop lines
    measure::FrfRequest closed_frf_request;
    std::optional<measure::FrfRun> closed_frf;  // the chosen loop's response on the stage
    double measured_bandwidth_Hz = 0.0;          // where its T falls below -3 dB (0: it stays above)
    std::vector<Verification> verification;  // the first is the check: 10 Hz over half the range
    // Every run on the stage within 2x its prediction + 2 % of its range, no
    // trip; otherwise why not (the result is then not kept).
    std::string verification_failure;
    // The fastest whole-range triangle within 1 % (fastest_triangle.hpp), and
    // when the 10 Hz one is not, what bounds the loop's bandwidth.
    std::optional<FastestTriangle> fastest;
    std::string fastest_text;
    bool verified() const { return chosen >= 0 && verification_failure.empty(); }
    std::vector<std::string> log;  // what was done, in order
};

// The whole sequence. Throws std::invalid_argument naming the option for a
// bad request (range beyond the travel or the command span, a bandwidth
// above what the measurement supports) and std::runtime_error with the
// reason when a safety step stops it (a trip, a sensor at its rail, no
// response, an inconsistent response). On return the chosen controller is
// loaded on the stage (when one passes), the loop disarmed.
Commissioning commission(StageAccess& stage, const CommissionRequest& r,
                         const std::function<void(const std::string&)>& progress = {});

// The identified stage with the chosen controller as its case "commissioned"
// (DIR/scenario.json).
nlohmann::json commissioned_scenario(const Commissioning& c);

// Where |T| first falls below -3 dB along the lines f_Hz (ascending),
// interpolated linearly in |T| on a log-frequency axis between the two lines
// around it; the first line if it starts below, 0 when it stays above.
double bandwidth_Hz(const std::vector<double>& f_Hz, const std::vector<design::cplx>& t);

// A fit's response at the measured lines, with the tick of delay the fit
// took out put back: what it is compared with the measurement by.
design::cplx fit_response(const ModelFit& fit, double f_Hz, double rate_Hz);

// The reference pre-filter of a model (continuous): for each of its two
// lowest lightly damped pole pairs (ζ < 0.2) below to_Hz, the pair as zeros
// and the same frequency at ζ 0.7 as poles, so the reference carries nothing
// at the mode and the filter has unit DC gain. None without such a mode.
std::optional<design::Zpk> reference_prefilter(const design::Zpk& model, double to_Hz);

// Step 1 from the steps' records (exposed for tests): throws
// std::runtime_error naming the step and the reason.
SafetyStep check_safety_step(const measure::StepRun& run, double step_V, double from_V, const measure::RangeUm& rails,
                             const SafetyStep* previous);

}  // namespace piezoloop::commission
