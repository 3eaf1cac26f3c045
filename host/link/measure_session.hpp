// Measurements on a board: `piezoloop --device ADDR measure frf |
// step | loops`.
// The request is checked and planned against the board's loop rate, the
// limits group in effect and its excitation capacity (measure/frf_plan), the
// core's excitation runs on the board (StartExcitation), the recorder streams
// r, y, u and d of every tick without loss (record_session), and the
// analysis is the simulator's (analyse_frf, analyse_step_run,
// analyse_loops_run): a board and `measure ... --scenario` differ only in
// where the recording comes from.
//
// Open loop the board's feedforward, feedback and repetitive controller are
// set to none for the measurement (u = limits(bias + d)) and put back
// afterwards, the loop left disarmed. Closed loop the board's own controller
// runs and holds the board's setpoint; d is added to its output.
#pragma once

#include <functional>
#include <string>

#include "link/client.hpp"
#include "link/record_session.hpp"
#include "measure/frf_plan.hpp"
#include "measure/step_loops_plan.hpp"

namespace piezoloop::hostlink {

struct MeasureOptions {
    // Emulated boards: the stage restarts at rest with the excitation, so the
    // recording equals the simulator's for the same stage (log hash).
    bool restart_stage = false;
    // The measured axis on a board of axes (its groups, its excitation and
    // its signals); the loop arms every axis, so every axis's limits group
    // must be set, and the others hold their setpoints with their own
    // controllers.
    uint8_t axis = 0;
    std::function<bool()> stop_requested;   // polled while recording (SIGINT)
    std::function<void(double)> progress;  // fraction of the recording received
};

// An axis's controller groups, which an open-loop measurement sets to none
// and puts back after it.
struct ControllerGroups {
    link::FeedforwardParams ff;
    link::FeedbackParams fb;
    link::RepetitiveParams rc;
};
ControllerGroups read_controller(Client& c, uint8_t axis);
void write_controller(Client& c, const ControllerGroups& g, uint8_t axis);
// The recorder group a measurement's recording replaces, put back after it
// (an unconfigured recorder reports its defaults, which are put back).
void restore_recorder(Client& c, const link::RecorderParams& before);

// plan_frf against what the board says (hello, limits group). Throws
// std::invalid_argument naming the option, before anything moves.
measure::FrfPlan plan_frf_device(Client& c, const measure::FrfRequest& r, uint8_t axis = 0);

struct DeviceFrfRun {
    measure::FrfRun run;
    RecordResult record;  // counts, loss, log hash (r, y, u of every tick)
};

// Runs the measurement. Throws std::invalid_argument for a request the board
// cannot take (nothing moved), LinkError when the board cannot be reached or
// the recording is incomplete (the board is left disarmed, its groups put
// back where the link still works).
DeviceFrfRun run_frf_device(Client& c, const measure::FrfRequest& r, const MeasureOptions& o = {});

// What a measurement's JSON says of its recording: frames, lost blocks,
// recorder and tick overruns, link frames the host dropped.
nlohmann::json recording_summary(const RecordResult& rec);

// A board's bounds for steps and loops: its loop rate, its limits group, and
// for a closed loop the core's position scale (+- full scale: the board does
// not know its stage's travel).
measure::MeasureBounds board_bounds(Client& c, uint8_t axis = 0);

// Closed loop the step is added to the setpoint the board holds (the offset
// brings the reference to `from` first).
measure::StepRun run_step_device(Client& c, const measure::StepRequest& r, const MeasureOptions& o = {});

// One recording per amplitude; log_hash stays 0 (the amplitudes are apart).
measure::LoopsRun run_loops_device(Client& c, const measure::LoopsRequest& r, const MeasureOptions& o = {});

}  // namespace piezoloop::hostlink
