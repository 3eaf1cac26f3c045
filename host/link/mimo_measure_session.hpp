// `piezoloop --device ADDR measure frf --mimo`: the n x n frequency response
// of a board's n coupled axes, one axis at a time (Pintelon & Schoukens 2012,
// ch. 3, allow either design: all inputs at once with orthogonal multisines,
// as the simulator's --mimo, or one input per experiment). The board's core
// runs the single-axis multisine (frf_plan.hpp: the same N, lines and
// Schroeder phases as measure/mimo_frf_plan.hpp), so each axis is excited
// by its own excitation generator, with no phase rotation across axes.
//
// Block b: every axis open loop (its controller groups set to none, put
// back afterwards), axis b's command bias + the multisine, every other
// axis's command held at its bias (an excitation of amplitude 0), for D + P
// periods from the multisine's first tick; the recorder takes u of axis b
// and y of every axis (n + 1 <= 4 channels). The estimate is
// measure::estimate_mimo_frf's, G = Ybar Ubar^-1, with Ubar diagonal here
// (each block's one input: its recorded u; the others their constant bias).
// The board's output matrix stays as it is: the response is y <- the axis
// commands, through it.
#pragma once

#include <vector>

#include <nlohmann/json.hpp>

#include "link/client.hpp"
#include "link/measure_session.hpp"
#include "link/record_session.hpp"
#include "measure/mimo_frf_estimate.hpp"
#include "measure/mimo_frf_plan.hpp"

namespace piezoloop::hostlink {

struct DeviceMimoFrfRun {
    measure::MimoFrfPlan plan;
    measure::MimoFrfEstimate estimate;
    std::vector<RecordResult> records;  // one per block
    uint64_t clipped_samples = 0;       // ticks any axis's limiter clamped or slew-limited, every block
    double wall_s = 0.0;
};

// The request of `measure frf --mimo` on this board: every axis, the
// board's loop rate, bias_V on every axis. std::invalid_argument (naming
// --mimo) on a board of one axis.
measure::MimoFrfRequest board_mimo_request(Client& c, double from_Hz, double to_Hz, double amplitude_V, double bias_V,
                                           int periods, int transient_periods);

// r.inputs must be the board's axis count (2 or 3), r.rate_Hz its loop
// rate, r.bias_V one per axis. Throws std::invalid_argument naming the
// option before anything moves (a board of one axis, a band or bias
// beyond an axis's limits, a running wave), LinkError if a recording is
// incomplete (the board left disarmed, the groups put back).
DeviceMimoFrfRun run_mimo_frf_device(Client& c, const measure::MimoFrfRequest& r, const MeasureOptions& o = {});

// The run's report: measure::mimo_frf_summary with the axes (x, y, z), the
// source (the board), the design, the output matrix (the board's), the
// clipped samples, each block's recording summary and the wall time.
nlohmann::json board_mimo_report(Client& c, const DeviceMimoFrfRun& run);

}  // namespace piezoloop::hostlink
