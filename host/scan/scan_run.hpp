// A scan on the simulator: the scenario's stage of coupled axes
// (CoupledStage, sim/coupled_stage_build.hpp) under a MultiAxisPipeline
// whose x and y (and z, held) setpoints a ScanFeed drives, with the virtual
// probe reading the sample where the stage truly is.
//
// Control: open loop. Each axis's command is its setpoint through a static
// gain, 1 / (nominal_um_per_V x the axis's amplifier gain) V per µm (a
// linear compensator with no play operator in the pipeline's feedforward;
// no feedback), so the images show the stage's own hysteresis, dynamics and
// coupling.
//
// Per tick: the feed sets the setpoints (the reading-independent half),
// the pipeline computes the commands from the previous tick's readings, the
// stage steps, and the tick is recorded: commanded (the setpoints), measured
// (the sensors' readings / their gains), true positions, the probe's height
// and the sync word. The stage starts at rest (0 V); the scan starts from
// its readings with the feed's approach; the approach is not recorded.
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
    ScanConfig scan{};  // sample_rate_Hz is the scenario's loop rate
    SampleSurface sample{};
    std::function<bool()> stop_requested;               // polled every 1024 ticks
    std::function<void(uint64_t tick, uint64_t total)> progress;  // every 2^15 ticks
};

struct ScanRunResult {
    std::vector<ScanTick> ticks;  // from the scan's first tick
    uint32_t approach_ticks = 0;
    uint32_t frames_completed = 0;
    bool complete = false;         // false: stopped before the last frame
    std::vector<double> V_per_um;  // each axis's static gain
    std::vector<double> travel_um; // each axis's command range at that gain: [lo, hi] pairs
};

// Each axis's static gain (V per µm) and the range it reaches within the
// command limits: [u_min_V, u_max_V] / gain.
std::vector<double> static_gains_V_per_um(const sim::Scenario& s);
std::pair<double, double> axis_travel_um(const sim::Scenario& s, int axis);

// Throws std::invalid_argument naming the field: a scenario of fewer than
// two axes, a scan the generator refuses (sim::describe'd Status, group
// "scan"), a scan that leaves an axis's travel ("scan.x" / "scan.y").
ScanRunResult run_scan(const sim::Scenario& s, const ScanRunOptions& o);

}  // namespace piezoloop::scan
