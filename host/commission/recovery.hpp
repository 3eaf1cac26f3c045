// Large-signal recovery of a commissioned loop: how long it takes to track
// again after its command has sat at a limit (docs/commissioning.md,
// "Recovery after saturation").
//
// The loop holds its centre, then its reference is driven far beyond the
// range, first above and then below, for hold_s each, which pins the command
// at the limiter's u_max_V, then u_min_V (the feedforward and the feedback
// both ask for more than the stage's command span). After each episode the
// reference is back at the centre, and the recovery time is how long what
// the loop holds, the reading without its noise and mains ((1 + gain error)
// (x + offset), x the stage's displacement), then takes to come within 0.1 %
// of the range of the centre for good. The
// reference is a step sequence of the core's trajectory generator
// (Waveform::kSteps), one cycle, in units of about 10 ms that divide hold_s:
//
//   centre (settle) | centre + beyond (hold) | centre (window) | centre - beyond (hold) | centre (window)
//
// The window is twice the bound 5 / bandwidth, at least 0.5 s, so "for good"
// is seen over at least as long again. With beyond_um inside the range the
// same run gives the loop's own (unsaturated) settling after a step back.
#pragma once

#include <array>
#include <string>

#include "commission/stage_access.hpp"
#include "sim/closed_loop.hpp"
#include "sim/scenario.hpp"

namespace piezoloop::commission {

struct RecoveryRequest {
    double centre_um = 0.0;     // held before, between and after the episodes
    double range_um = 0.0;      // > 0: the tolerance is 0.1 % of it
    double bandwidth_Hz = 0.0;  // > 0: the closed loop's; the bound is 5 / bandwidth_Hz
    double beyond_um = 0.0;     // the reference's distance from the centre in an episode (0: 3 x range;
                                // at most the position full scale's room)
    double hold_s = 0.2;        // each episode's length, [0.01, 0.5] s
    sim::SampleType sample = sim::SampleType::kFloat;
};

struct RecoveryEpisode {
    int direction = 0;          // +1: the reference above the range, -1: below
    double clamped_s = 0.0;     // how long the command sat at the limit during the episode
    double recovery_s = -1.0;   // from the reference's return until |x - centre| < tolerance for good; -1: not in the window
};

struct RecoveryRun {
    double tolerance_um = 0.0;      // 0.1 % of the range
    double bound_s = 0.0;           // 5 / bandwidth
    double settled_error_um = 0.0;  // max |x - centre| over the last 0.1 s before the first episode
    std::array<RecoveryEpisode, 2> episodes{};
    std::string trip;               // the limiter's trip reason at the end ("none")
    double wall_s = 0.0;
};

// The episode above on `stage` with the controller k (as
// controller_case(k, r.sample) builds it). Throws std::invalid_argument
// naming the field for a bad request or a case the core rejects.
RecoveryRun saturation_recovery(const sim::Scenario& stage, const Controller& k, const RecoveryRequest& r);

}  // namespace piezoloop::commission
