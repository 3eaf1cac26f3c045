// Commissioning a stage the tool has not seen (issue 17, docs/commissioning.md):
// from measurements alone to a checked controller, on the simulator
// (`piezoloop commission --scenario S`). Each step is a function of what the
// previous measured, so a board session can run the same steps with the
// board's measurements (link/measure_session).
//
//   1. safety: open-loop command steps of 2, 5 and 10 % of the command span
//      from mid-span; each must move the stage (|Δy| above 5x the noise),
//      off the sensor's rails, with the gain of the previous step within
//      ±50 % (same sign); the gain estimate g0 (µm/V) checks the range.
//   2. frequency response: open loop about mid-span, 5 % of the span.
//   3. model: continuous fits of order 2, 4, 6, 8 (zeros one fewer, one tick
//      of delay taken out); the lowest whose RMS relative error on the lines
//      with SNR >= 20 dB is below 10 % (the hysteresis bends a stage's
//      response by several %), else the best.
//   4. candidates on the fitted model normalised to unit DC gain: robust,
//      mixed-sensitivity H∞ (plant reduced to 6 states if larger, W1 =
//      (s/1.6 + ω_b)/(s + 1e-3 ω_b) at the target bandwidth, W2 = 0.5), and
//      classic, PI + notches (synth/pi_notch) at the target bandwidth.
//   5. each checked on the measured response (analysis/measured_loop):
//      PM >= 45°, GM >= 6 dB, max|S| <= 2; a candidate that fails is never
//      chosen.
//   6. each passing candidate tracks a triangle over half the range at 10 Hz
//      on the stage (simulated); the lower e_max is chosen.
#pragma once

#include <functional>
#include <optional>
#include <string>
#include <vector>

#include "analysis/measured_loop.hpp"
#include "lti/lti.hpp"
#include "measure/frf_plan.hpp"
#include "measure/step_loops_plan.hpp"
#include "measure/tf_fit.hpp"
#include "sim/scenario.hpp"

namespace piezoloop::commission {

struct CommissionRequest {
    double range_um = 0.0;             // the travel the loop must hold
    double target_bandwidth_Hz = 0.0;  // 0: a third of the first lightly damped mode, at most rate / 100
};

struct SafetyStep {
    double step_V = 0.0, from_V = 0.0;
    double dy_um = 0.0, noise_um = 0.0, gain_um_per_V = 0.0;
};

struct ModelFit {
    int poles = 0, zeros = 0;
    double rms_rel = 0.0;               // |G_fit - G| / |G|, RMS over the lines with SNR >= 20 dB
    design::Zpk model;                  // continuous, u (V) -> y (µm), delay left out
    double dc_gain_um_per_V = 0.0;
};

struct Candidate {
    std::string name;          // robust | classic
    std::string method;        // how it was made
    design::Zpk controller;    // continuous, e (µm) -> u (V)
    int order = 0;
    double design_crossover_Hz = 0.0;
    design::MeasuredLoop measured;  // on the measured lines
    bool passes = false;
    std::string refusal;       // why it fails the checks or could not be made
    std::optional<double> e_max_pct_10Hz, e_rms_pct_10Hz, e_max_pct_1Hz;  // simulated tracking
};

struct Commissioning {
    std::vector<SafetyStep> safety;
    double gain_um_per_V = 0.0;
    measure::FrfRun frf;
    measure::FrfRequest frf_request;
    std::vector<ModelFit> fits;  // every order tried
    int chosen_fit = -1;
    double target_bandwidth_Hz = 0.0;
    std::vector<Candidate> candidates;
    int chosen = -1;             // index into candidates; -1: none passes
    std::vector<std::string> log;  // what was done, in order
};

// The whole sequence on a scenario's stage (open loop: no case). Throws
// std::invalid_argument naming the option for a bad request (range beyond
// the travel or the command span, a bandwidth above what the measurement
// supports) and std::runtime_error with the reason when a safety step stops
// it (a trip, a sensor at its rail, no response, an inconsistent response).
Commissioning commission_sim(const sim::Scenario& s, const CommissionRequest& r,
                             const std::function<void(const std::string&)>& progress = {});

// Step 1 from the steps' records (exposed for tests): throws
// std::runtime_error naming the step and the reason.
SafetyStep check_safety_step(const measure::StepRun& run, double step_V, double from_V, const measure::RangeUm& rails,
                             const SafetyStep* previous);

}  // namespace piezoloop::commission
