// `measure frf` against the simulator (issue 16): the scenario's stage and
// the core's pipeline with its excitation (common/piezoloop/excitation.hpp),
// stepped by the loop kernel every simulated run uses (sim/loop_kernel.hpp),
// so the recording is the one a board running the same excitation makes.
// The analysis is frf_estimate's, shared with the board path: the periodic
// estimate for a multisine, H1 with Welch averaging for a sweep or a PRBS.
//
// Open loop: no controller, u = limits(bias + d). Closed loop: the case's
// controller holds the setpoint (the bias converted at the stage's mean
// slope) and d is added to its command, u = limits(controller + d); the
// estimate Ybar / Ubar is then still the plant's (frf_estimate.hpp).
#pragma once

#include <cstdint>
#include <functional>
#include <string>
#include <vector>

#include "measure/frf_estimate.hpp"
#include "sim/scenario.hpp"

namespace piezoloop::measure {

struct FrfRequest {
    std::string signal = "multisine";  // multisine | sweep | prbs
    double from_Hz = 0.0, to_Hz = 0.0;
    double amplitude_V = 0.0;  // peak of d at the command
    double bias_V = 0.0;
    bool closed = false;
    int periods = 10;          // measured periods (P)
    int transient_periods = 1; // run first and discarded
};

// The excitation a request makes on a scenario.
//   multisine: N = floor(rate / from_Hz) (the line spacing rate / N is at
//     most from_Hz), lines k1..k2 covering [from_Hz, to_Hz] on the DFT grid.
//   sweep, prbs: Welch segments of S = the power of two >= rate / from_Hz
//     samples (resolution <= from_Hz); lines are the FFT bins in the band.
//     sweep: from_Hz -> to_Hz over 4 S samples per period; prbs: each bit
//     held h = max(1, floor(0.4 rate / to_Hz)) samples (its spectrum is
//     within 1.5 dB of flat up to to_Hz), order n the smallest with
//     (2^n - 1) h >= S.
struct FrfPlan {
    std::string signal = "multisine";
    MultisineLayout layout;       // multisine
    uint32_t period_samples = 0;  // one period of the excitation
    uint32_t segment_samples = 0; // sweep, prbs: Welch segment
    uint32_t prbs_order = 0, prbs_hold = 1;
    uint64_t ticks = 0;           // (transient + P) periods
    uint64_t measured_start = 0;  // transient periods
};

// Largest period the simulator's pipeline tabulates (the lowest from_Hz is rate / this).
inline constexpr uint32_t kSimExcitationCapacity = 16384;

// Checks the request against the scenario before anything runs; throws
// std::invalid_argument naming the option and the allowed range.
FrfPlan plan_frf(const sim::Scenario& s, const FrfRequest& r);

struct FrfRun {
    FrfPlan plan;
    FrfEstimate estimate;
    std::vector<double> coherence;       // sweep, prbs
    int segments = 0;                    // sweep, prbs: Welch segments averaged
    uint32_t clipped_samples = 0;        // in the measured periods (clamped or slew-limited)
    uint32_t clipped_transient = 0;      // in the discarded ones
    std::string trip = "none";
    double wall_s = 0.0;
    uint64_t log_hash = 0;               // r, y, u of every tick, as `sim --hash`
    std::vector<std::string> warnings;
};

// case_spec: the controller (closed loop) and any hysteresis override of the
// case (open loop); null: the scenario's stage, open loop.
FrfRun run_frf_sim(const sim::Scenario& s, const sim::CaseSpec* case_spec, const FrfRequest& r,
                   const std::function<void(double)>& progress = {});

}  // namespace piezoloop::measure
