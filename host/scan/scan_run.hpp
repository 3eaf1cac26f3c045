// A scan on the simulator: the scenario's case on its stage of coupled axes
// (sim/multi_axis_loop.hpp's build_multi_axis_case: every axis's controller
// built alone, the CoupledStage, the matrices, float or Q31) in a
// MultiAxisPipeline whose x and y (and z, held) setpoints a ScanFeed drives,
// with the virtual probe reading the sample where the stage truly is.
//
// Per tick, as multi_axis_loop.hpp runs a tick (LoopStepper's arithmetic):
// the feed sets the setpoints (the reading-independent half), the pipeline
// computes the commands from the previous tick's readings, the stage steps,
// and the tick is recorded: commanded (the setpoints), measured (the
// core's readings, after the input matrix), true positions, the probe's
// height and the sync word. The stage starts at rest (0 V) and is read for one tick
// with every axis holding 0; the scan then starts from those readings with
// the feed's approach (not recorded).
#pragma once

#include <cstdint>
#include <functional>
#include <string>
#include <vector>

#include "piezoloop/scan/scan_config.hpp"
#include "scan/sample_surface.hpp"
#include "scan/scan_tick.hpp"
#include "sim/scenario.hpp"

namespace piezoloop::scan {

struct ScanRunOptions {
    std::string case_name;  // the scenario's case
    ScanConfig scan{};      // sample_rate_Hz is the scenario's loop rate
    SampleSurface sample{};
    // Start as a board starts StartScan with the loop's arm and the stage's
    // restart (false: the simulator's own start, see scan_run.cpp).
    bool board_start = false;
    std::function<bool()> stop_requested;               // polled every 1024 ticks
    std::function<void(uint64_t tick, uint64_t total)> progress;  // every 2^15 ticks
};

struct ScanRunResult {
    std::vector<ScanTick> ticks;  // from the scan's first tick
    uint32_t approach_ticks = 0;
    uint32_t frames_completed = 0;
    bool complete = false;         // false: stopped before the last frame
    bool q31 = false;              // the case's sample type
};

// The period axis's (0: x, 1: y) repetitive controller learns over on a
// scan (ticks): a raster's line (two when bidirectional), a turn of a
// constant-angular-velocity spiral (each axis a sinusoid of slowly changing
// amplitude: the RC learns from the turn before), a Lissajous axis's own
// sinusoid when it repeats after whole ticks, else the frame (CLV spiral).
// c as ScanGenerator::configure accepts it.
uint32_t scan_rc_period_ticks(const ScanConfig& c, int axis);

// An axis's travel: its hard command range [u_min_V, u_max_V] times the
// stage's mean slope (nominal_um_per_V x the axis's amplifier gain).
std::pair<double, double> axis_travel_um(const sim::Scenario& s, int axis);

// Throws std::invalid_argument (or ScenarioError) naming the field: a
// scenario of fewer than two axes, an unknown case, a scan the generator
// refuses (group "scan"), a scan that leaves an axis's travel ("scan.x" /
// "scan.y").
ScanRunResult run_scan(const sim::Scenario& s, const ScanRunOptions& o);

}  // namespace piezoloop::scan
