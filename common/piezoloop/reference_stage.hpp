// The reference stage and controller that the demo, the benchmarks, the
// tests and the firmware self-test share, so every figure they print refers
// to the same loop.
//
// Stage: Janaideh2016's 15-operator PI model (docs/models.md, 'Janaideh2016', ±10 V in, ±44 µm
// out) feeding a lightly damped 1 kHz resonance (zeta 0.05), at 100 kHz. The
// simulated stage is not exactly that model: its linear weight is 5 % higher
// and its play weights 10 % lower, the kind of mismatch identification leaves,
// so feedback has real work to do.
// Controller: inverse-PI feedforward of the published model, and a 6th-order
// feedback as 3 sections, µm -> V:
//   s1: k_i / ((s + 2 pi 0.1 Hz)(s / (2 pi 20 kHz) + 1))  near-integrator
//   s2: notch on the resonance (zeros zeta 0.05, poles zeta 0.7)
//   s3: 2nd-order low-pass at 5 kHz (zeta 0.7)
// k_i = 235 V/(µm s) puts the crossover near 150 Hz for the stage's mean
// slope (~4 µm/V) that u_fb sees around the feedforward. The repetitive
// controller (N = 100: 1 kHz references) and the recorder complete the
// "all blocks" pipeline the budgets are measured on.
//
// The RC in this loop (all_blocks_params): with the published Q (cutoff
// ~7 kHz) it is unstable here. The loop's crossover is held near 150 Hz by
// the 1 kHz resonance, so its closed-loop phase passes 90° at 240-310 Hz
// (over the hysteresis' local slope, 2.7-4.4 µm/V), far below Q's cutoff,
// and the small-gain condition |Q| |1 - k_rc T| < 1 (docs/models.md,
// 'Repetitive control') peaks at 1.14-1.24 near 500 Hz: the RC's correction
// grows every period until the output limits (float) or the Q31 delay
// line's full scale (±50 µm: a bounded oscillation instead) stop it, and
// the two cores part. A smaller k_rc does not cure it (the phase condition
// does not depend on it). Q cut off at 200 Hz instead, below the 240 Hz
// where the phase reaches 90°, satisfies both conditions (small-gain peak
// 0.65-0.75, from the discretised loop). The RC then cannot learn the
// 1 kHz harmonics of its period N = 100 (no RC can, in a loop this slow);
// it runs, stable, in the loop, so every block's arithmetic is exercised
// on signals of a loop that tracks.
#pragma once

#include "piezoloop/det_math.hpp"
#include "piezoloop/pi_inverse.hpp"
#include "piezoloop/pipeline.hpp"
#include "piezoloop/plant.hpp"
#include "piezoloop/tustin.hpp"

namespace piezoloop::reference {

inline constexpr float kRate_Hz = 100000.0f;
inline constexpr double kPi = 3.14159265358979323846;

inline constexpr float kThresholds15[] = {0.095f, 0.38f, 0.84f, 1.46f, 2.21f, 3.07f, 4.01f, 4.98f,
                                          5.96f, 6.89f, 7.76f, 8.52f, 9.14f, 9.61f, 9.9f};
inline constexpr float kWeights15[] = {2.55f, 0.57f, 1.3f, -1.57f, 1.25f, -0.054f, -0.032f, 0.66f,
                                       0.16f, -0.77f, 2.02f, -1.63f, -0.15f, 2.99f, -1.09f};

// Janaideh2016's model, with the rule for thresholds starting above zero.
constexpr PiModel stage_model() {
    PiModel m{};
    (void)pi_model_from_lists(kThresholds15, kWeights15, 15, nullptr, m);
    return m;
}

constexpr PipelineSetup setup() {
    PipelineSetup s{};
    s.hard = HardLimits{-10.0f, 10.0f, 2.0e5f};  // the bender's rated ±10 V
    s.rate_Hz = kRate_Hz;
    s.position = SignalScale{50.0f};
    s.voltage = SignalScale{12.0f};
    return s;
}

// The simulated stage: the published model with a deliberate mismatch.
constexpr PiModel true_stage_model() {
    PiModel m = stage_model();
    m.p0 *= 1.05f;
    for (int j = 0; j < m.count; ++j) m.weights[static_cast<unsigned>(j)] *= 0.9f;
    return m;
}

// At another loop rate (the self-test's multi-axis case on the M3 runs at
// 50 kHz): the same continuous design discretised at rate_Hz.
constexpr PlantConfig plant(float rate_Hz = kRate_Hz) {
    PlantConfig c{};
    c.hysteresis = HysteresisKind::kPi;
    c.pi = true_stage_model();
    c.sections = 1;
    (void)tustin(resonance(1e3, 0.05), rate_Hz, c.dynamics[0]);
    return c;
}

// Feedback sections (µm -> V), discretised with Tustin at the loop rate.
constexpr void feedback_sections(SosSection* out, float rate_Hz = kRate_Hz) {
    const double w_i = 2.0 * kPi * 0.1, w_r = 2.0 * kPi * 1e3, w_lp = 2.0 * kPi * 5e3, w_hf = 2.0 * kPi * 20e3;
    const double k_i = 235.0;
    // k_i / ((s + w_i)(s / w_hf + 1)) = k_i w_hf / (s^2 + (w_i + w_hf) s + w_i w_hf)
    (void)tustin(ContinuousSection{0.0, 0.0, k_i * w_hf, 1.0, w_i + w_hf, w_i * w_hf}, rate_Hz, out[0]);
    (void)tustin(ContinuousSection{1.0, 2.0 * 0.05 * w_r, w_r * w_r, 1.0, 2.0 * 0.7 * w_r, w_r * w_r},
                 rate_Hz, out[1]);
    (void)tustin(ContinuousSection{0.0, 0.0, w_lp * w_lp, 1.0, 2.0 * 0.7 * w_lp, w_lp * w_lp}, rate_Hz,
                 out[2]);
}

// What the demo calls feedforward + feedback, with RC on when `with_rc`.
constexpr PipelineParams params(bool feedforward = true, bool feedback = true, bool with_rc = false,
                                float rate_Hz = kRate_Hz) {
    PipelineParams p{};
    p.feedforward = feedforward ? FeedforwardKind::kPiInverse : FeedforwardKind::kNone;
    p.pi = stage_model();
    p.feedback = feedback ? FeedbackKind::kSos : FeedbackKind::kNone;
    p.sos_count = 3;
    feedback_sections(p.sos.data(), rate_Hz);
    p.rc_enabled = with_rc;
    p.rc = RepetitiveConfig{};
    p.rc.m1 = 3;  // Q's low-frequency group delay (see tests/common/test_repetitive.cpp)
    p.limits = LimitsConfig{-10.0f, 10.0f, 2.0e5f, 0.0f};
    return p;
}

// The RC's Q for the reference loop: first order with unit DC gain,
// Q(z) = (1 - a) / (z - a), a = e^(-2 pi 200 Hz Ts) (the published Q's form,
// 0.3558 / (z - 0.6442), with its pole moved from ~7 kHz to 200 Hz).
inline constexpr double kRcQCutoff_Hz = 200.0;
constexpr SosSection rc_q(float rate_Hz = kRate_Hz) {
    const double a = det_exp(-2.0 * kPi * kRcQCutoff_Hz / static_cast<double>(rate_Hz));
    return SosSection{0.0, 1.0 - a, 0.0, -a, 0.0};
}

// Feedforward, feedback and the RC in the loop with the Q above: the "all
// blocks" pipeline of the firmware self-test and its block profile.
constexpr PipelineParams all_blocks_params(float rate_Hz = kRate_Hz) {
    PipelineParams p = params(true, true, true, rate_Hz);
    p.rc.q = rc_q(rate_Hz);
    return p;
}

// Open loop means: the feedforward alone, or a plain scaling of r by the
// stage's mean slope when there is no model at all.
constexpr PipelineParams open_loop_params() {
    PipelineParams p = params(false, false, false);
    p.feedforward = FeedforwardKind::kPiCompensator;
    p.pi = PiModel{};
    p.pi.p0 = 1.0f / 4.4f;  // µm -> V at the loading curve's mean slope
    return p;
}

}  // namespace piezoloop::reference
