// A scan on a board of two or three axes (StartScan, docs/scan.md): the
// board's recorder takes x's and y's readings and the sync word every tick,
// the scan starts with the recorder (and the loop, if disarmed) at one tick,
// and the record becomes the same per-tick rows a scan on the simulator
// gives (scan/scan_run.hpp), so both are analysed and written alike:
//   commanded  the scan's path, computed here with the board's own
//              generator and sample type (ScanGenerator is bit-identical on
//              every target), from the scan's first tick after its approach;
//   measured   each axis's y as the board's core has it (after the input
//              matrix);
//   sync       the board's recorded sync word;
//   true, height: a board streams no true position, so true_* are NaN and
//              the emulated sample is read at the measured position.
// Ctrl-C (stop_requested) stops the scan on the board and keeps what
// arrived, marked incomplete.
#pragma once

#include <functional>
#include <string>
#include <vector>

#include "link/client.hpp"
#include "piezoloop/scan/scan_config.hpp"
#include "scan/sample_surface.hpp"
#include "scan/scan_case.hpp"
#include "scan/scan_run.hpp"
#include "sim/scenario.hpp"

namespace piezoloop::hostlink {

struct DeviceScanOptions {
    ScanConfig scan{};             // sample_rate_Hz: the board's loop rate
    scan::SampleSurface sample{};  // read at the measured positions
    bool restart_stage = false;    // emulated stage and loop from rest (StartScan's bit2)
    // x's and y's repetitive controllers, when enabled, set to the scan's
    // period (scan_rc_period_ticks) first; otherwise a different period is
    // only noted.
    bool rc_period_from_scan = false;
    double stall_s = 5.0;          // give up when no frames arrive for this long
    std::function<bool()> stop_requested;
    std::function<void(uint64_t tick, uint64_t total)> progress;
};

struct DeviceScanResult {
    scan::ScanRunResult run;
    std::vector<std::string> notes;  // the repetitive controllers' periods: set, or unlike the scan's
    std::string problems;        // why it is incomplete ("" when complete)
    uint32_t sync_mismatches = 0;  // recorded sync words that differ from the generator's
};

// Throws std::invalid_argument when the board runs no scans (cap::kScan) or
// is tripped, DeviceError when it refuses the scan (naming the field), and
// LinkError for a failure before the scan starts; a failure after it ends
// the record early instead (result.problems).
DeviceScanResult run_scan_device(Client& c, const DeviceScanOptions& o);

// A scan as a user asks for it (scan_case.hpp) on the board, planned, run
// and analysed as `piezoloop scan` and Python's Device.scan do. The scan is
// checked against the travel of `stage` (the scenario of the stage the
// board drives, as `emulate --scenario` runs it; its loop rate must be the
// board's) or, when null, against the board's position range, the centre
// then given. std::invalid_argument names the request's field as `name`
// spells it (scenario, centre_um, and plan_scan's).
// The plan alone (nothing moves), and the stage's name for the figures.
scan::ScanPlan plan_board_scan(Client& c, const scan::ScanRequest& r, const sim::Scenario* stage,
                               const scan::FieldName& name, std::string* label = nullptr);
struct BoardScan {
    scan::ScanPlan plan;
    scan::ScanOutcome outcome;  // figures add device, sync_mismatches, probe, rc (the notes), incomplete
    double rate_Hz = 0.0;
    std::string problems;       // why it is incomplete ("" when complete)
};
struct BoardScanOptions {
    bool restart_stage = false;
    bool rc_period_from_scan = false;
    std::function<bool()> stop_requested;
    std::function<void(uint64_t tick, uint64_t total)> progress;
};
BoardScan scan_on_board(Client& c, const scan::ScanRequest& r, const sim::Scenario* stage, const scan::FieldName& name,
                        const BoardScanOptions& o);

}  // namespace piezoloop::hostlink
