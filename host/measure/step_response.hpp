// Step-response figures from a recorded response (`measure step`):
// overshoot, 10-90 % rise time, settling time into a band, final value. Pure
// analysis of arrays, shared by the simulator and (later) the board path, and
// testable against analytic responses without either.
//
// Definitions (Franklin, Powell & Emami-Naeini, Feedback Control of Dynamic
// Systems, 7th ed., §3.4), with t = 0 at the sample where the step is applied:
//   initial   mean of the samples before the step (the level it starts from);
//   final     mean of the last `final_fraction` of the samples after it (a
//             mean, so sensor noise does not move the reference level);
//   z(t)      (y(t) - initial) / (final - initial), 0 -> 1 for either sign;
//   overshoot max(0, max z - 1) x 100 %;
//   rise      t(z first reaches 0.9) - t(z first reaches 0.1);
//   settling  the time after which |z - 1| stays <= band (0.02: 2 %).
// Crossing times are linearly interpolated between samples, so a smooth
// response sampled at Ts gives them to far better than Ts.
#pragma once

#include <cstddef>
#include <span>
#include <stdexcept>

namespace piezoloop::measure {

// A record in which the reading does not move at all (a stage that does not
// respond, or a sensor pinned at a rail): a finding about the stage, not bad
// input.
struct NoStepResponse : std::runtime_error {
    using std::runtime_error::runtime_error;
};

struct StepOptions {
    double settle_band = 0.02;     // fraction of |final - initial|
    double final_fraction = 0.1;   // tail of the record averaged for the final value
};

struct StepFigures {
    double initial = 0.0, final_value = 0.0;  // in y's unit
    double overshoot_pct = 0.0;
    double peak = 0.0, peak_time_s = 0.0;     // the extreme of y in the step's direction
    double rise_time_s = 0.0;                 // NaN if z never reaches 0.9
    double settling_time_s = 0.0;             // NaN if the record ends outside the band
    bool settled = false;
};

// y: the record, sample_period_s apart; step_index: the first sample at or
// after the step (t = 0 there); needs at least one sample before it and two
// after. Throws std::invalid_argument if the record cannot define a step
// (too short, non-finite samples), NoStepResponse if final == initial.
StepFigures analyse_step(std::span<const double> y, double sample_period_s, std::size_t step_index,
                         const StepOptions& o = {});

}  // namespace piezoloop::measure
