// Where commissioning measures and verifies (commission/commission.hpp): the
// simulator's stage (commission/sim_stage) or a board over the link
// (link/board_stage). The sequence sees only what an implementation
// measures, so a board and `--scenario` run the same steps.
#pragma once

#include <optional>
#include <string>

#include "lti/lti.hpp"
#include "measure/frf_plan.hpp"
#include "measure/step_loops_plan.hpp"
#include "commission/tracking_diagnosis.hpp"
#include "piezoloop/pi_model.hpp"

namespace piezoloop::commission {

// What commissioning loads: a feedback controller and, where it helps, a
// hysteresis compensator on the reference and a pre-filter of the reference.
struct Controller {
    design::Zpk feedback;                 // continuous, e (µm) -> u (V), Tustin at the loop rate; in series: e -> µm
    std::optional<PiModel> feedforward;   // r (µm) -> u (V): the fitted PI model's analytic inverse
    std::optional<design::Zpk> prefilter; // r (µm) -> r (µm), continuous: notches at the lightly damped modes
    // The inverse in series after the feedback (the core's pi_series,
    // Shan2012's structure): u = limits(P^-1(r + u_fb)), u_fb in µm. The loop
    // then sees the stage linearised by the inverse at every amplitude.
    bool series = false;
};

// A triangle centred on a displacement (a range held inside what the
// command reaches, wherever the stage's zero is).
struct TrackRequest {
    double frequency_Hz = 10.0;
    double range_um = 0.0;   // peak-to-peak
    double centre_um = 0.0;
};

// Tracking over the last period of two (the first takes the start).
struct TrackingRun {
    double e_max_um = 0.0, e_rms_um = 0.0, e_max_pct = 0.0, e_rms_pct = 0.0;
    double hysteresis_pct = -1.0;  // y against r; negative: undefined
    std::string trip = "none";
    TrackingDiagnosis diagnosis;   // over the last period
    TrackingDiagnosisInputs diagnosis_inputs;
};

// The loop the stage runs in: its rate, sample type and Q31 full scales.
struct LoopFacts {
    double rate_Hz = 0.0;
    bool q31 = false;
    double position_full_scale_um = 0.0, voltage_full_scale_V = 0.0;
};

class StageAccess {
public:
    virtual ~StageAccess() = default;
    virtual std::string describe() const = 0;
    virtual LoopFacts loop() = 0;
    virtual measure::MeasureBounds bounds() = 0;
    // As `measure step` / `measure frf` / `measure loops` run them: open
    // loop, and a closed-loop frequency response with the controller track()
    // loaded last.
    virtual measure::StepRun step(const measure::StepRequest& r) = 0;
    virtual measure::FrfRun frf(const measure::FrfRequest& r) = 0;
    virtual measure::LoopsRun loops(const measure::LoopsRequest& r) = 0;
    // Runs the controller on the triangle (repetitive control off); the loop
    // is left disarmed with the controller loaded.
    virtual TrackingRun track(const Controller& k, const TrackRequest& t) = 0;
};

}  // namespace piezoloop::commission
