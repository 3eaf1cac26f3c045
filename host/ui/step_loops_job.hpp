// The console's step response and hysteresis loops: the forms' requests,
// made and planned as `piezoloop --device ADDR measure step | loops` make
// and plan them (measure/step_loops_report, step_loops_plan: the same
// defaults, checks and messages, with the form's field names), the run on
// the board (BoardSession::measure_step, measure_loops) as a
// MeasurementJob, and the results every page is sent: the CLI's report
// (figures, definitions, warnings, log hash) with the recorded samples.
#pragma once

#include <optional>
#include <string>
#include <vector>

#include <nlohmann/json.hpp>

#include "measure/step_loops_report.hpp"
#include "ui/board_session.hpp"
#include "ui/field_refusal.hpp"
#include "ui/measurement_job.hpp"

namespace piezoloop::ui {

// {mode: "open"|"closed"|"", step_V, bias_V (open), step_um, from_um
// (closed), duration_s, restart_stage}; a number left out or null is not
// given (the CLI's option left out).
struct StepForm {
    measure::StepInput input;
    bool restart_stage = false;
    std::string axis;  // a board of axes: the measured axis (x, y, z)
};
StepForm parse_step_form(const nlohmann::json& j);

// {amplitudes_V: [a, ...], bias_V (null: the default), frequency_Hz,
// cycles, shape: "triangle"|"sine", restart_stage}.
struct LoopsForm {
    std::vector<double> amplitudes_V;
    std::optional<double> bias_V;
    double frequency_Hz = 1.0;
    int cycles = 2;
    std::string shape = "triangle";
    bool restart_stage = false;
    std::string axis;  // a board of axes: the measured axis (x, y, z)
};
LoopsForm parse_loops_form(const nlohmann::json& j);

// A request or plan message of `measure step` / `measure loops` at the
// form's field ("--step-v: ..." -> step_V).
FieldRefusal step_refusal(const std::string& message);
FieldRefusal loops_refusal(const std::string& message);

// Checks the form against the board and plans it (FieldRefusal, BoardBusy)
// before anything moves, and returns the work that runs it: its result is
// step_report / loops_report with "request" (the form) and, for the loops,
// the samples (time_s, u_V, y_um, amplitude_V).
MeasurementJob::Work step_work(BoardSession& board, const nlohmann::json& form);
MeasurementJob::Work loops_work(BoardSession& board, const nlohmann::json& form);

// The results as the CLI writes them: `measure step --csv` (t,r,u,y) and
// `measure loops --out` (t,u,y,v,x,amplitude_V); "" for null.
std::string step_csv(const nlohmann::json& result);
std::string loops_csv(const nlohmann::json& result);

}  // namespace piezoloop::ui
