// `measure frf`'s request, plan and result, and the analysis of a recording
// shared by the simulator (frf_sim.hpp) and a board
// (frf_device.hpp): the request is checked and planned the same way, the
// excitation is the core's (common/piezoloop/excitation.hpp), and the
// estimate is frf_estimate's, the periodic one for a multisine, H1 with
// Welch averaging for a sweep or a PRBS.
#pragma once

#include <cstdint>
#include <limits>
#include <string>
#include <vector>

#include "measure/frf_estimate.hpp"
#include "piezoloop/excitation.hpp"
#include "piezoloop/limits.hpp"

namespace piezoloop::measure {

struct FrfRequest {
    std::string signal = "multisine";  // multisine | sweep | prbs
    double from_Hz = 0.0, to_Hz = 0.0;
    double amplitude_V = 0.0;  // peak of d at the command
    double bias_V = 0.0;
    bool closed = false;
    // Closed loop: the displacement the loop holds while d excites it; NaN
    // holds the bias's displacement at the scenario's mean slope.
    double setpoint_um = std::numeric_limits<double>::quiet_NaN();
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
//     (2^n - 1) h >= S, and S at most 2^20 samples.
// The whole run, (transient + P) periods, is at most kMaxRecordTicks
// (record_bound.hpp).
struct FrfPlan {
    std::string signal = "multisine";
    MultisineLayout layout;       // multisine
    uint32_t period_samples = 0;  // one period of the excitation
    uint32_t segment_samples = 0; // sweep, prbs: Welch segment
    uint32_t prbs_order = 0, prbs_hold = 1;
    uint64_t ticks = 0;           // (transient + P) periods
    uint64_t measured_start = 0;  // transient periods
};

// A multisine's lines for the band [from_Hz, to_Hz] at `rate` (the rule
// above: N = floor(rate / from_Hz), bins k1..k2 of N in the band, k2 < N / 2).
// The caller has checked 0 < from_Hz < to_Hz < rate / 2 and that N fits;
// throws std::invalid_argument naming --to-hz when no bin lies in the band.
MultisineLayout multisine_lines(double rate_Hz, double from_Hz, double to_Hz);

// Checks the request against the loop rate, the command limits in effect
// and the longest multisine period the pipeline tabulates (`capacity`)
// before anything runs; throws std::invalid_argument naming the option and
// the allowed range (`whose` names the limits: "scenario's", "board's").
FrfPlan plan_frf(double rate_Hz, const LimitsConfig& limits, uint32_t capacity, const FrfRequest& r,
                 const std::string& whose);

// The excitation a plan makes (at the command; sample rate the loop's).
ExcitationConfig excitation_config(const FrfPlan& plan, const FrfRequest& r);

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
    // Closed loop: the loop's own sensitivity S = U / D at the plant input
    // (d added to the controller's output) and T = 1 - S, at the same lines.
    std::vector<cplx> sensitivity, complementary_sensitivity;
    std::vector<std::string> warnings;
    // The reading's extremes over the measured periods and how many samples
    // sat exactly at each: a sensor (or ADC) rail holds the reading at one
    // value, which a caller that knows the rails can tell (commission).
    double y_min_um = 0.0, y_max_um = 0.0;
    std::size_t y_at_min = 0, y_at_max = 0;
};

// The estimate from the measured periods of a recording (u in V, y in um, d
// the excitation; d is used in closed loop only), then the warnings
// (clipping, trip, low coherence, large variance): the part of a
// measurement that does not depend on where the recording came from.
void analyse_frf(const FrfRequest& r, const std::vector<double>& u, const std::vector<double>& y,
                 const std::vector<double>& d, FrfRun& run);

}  // namespace piezoloop::measure
