// The console's commissioning: `piezoloop commission` (cli/commission_session,
// commission/commission) on the console's board, or, when the console was
// started with --scenario, on that scenario's simulated stage (the same
// stage, simulated: a run of seconds instead of half a minute, nothing
// loaded on the board). Its steps and decisions go to the progress's log as
// they are made, the recordings' fractions to its bar; the result is the
// summary `piezoloop commission` prints, with the report's tables (safety
// steps, fits, candidates, verification), report.md and the names of its
// figures, written to a fresh directory.
#pragma once

#include <string>
#include <vector>

#include <nlohmann/json.hpp>

#include "commission_session.hpp"
#include "ui/board_session.hpp"
#include "ui/field_refusal.hpp"
#include "ui/measurement_job.hpp"

namespace piezoloop::ui {

// {range_um, target_bandwidth_Hz (null or 0: automatic), save (board),
//  on: "board" | "simulator", axis | axes}.
struct CommissionForm {
    commission::CommissionRequest request;
    bool save = true;
    bool simulator = false;
    std::string axis;  // a board of axes: the axis commissioned (x, y, z)
    // A stage of axes commissioned whole (`commission --axes`): every axis
    // named ("all": each of them), then the output matrix that decouples
    // them; empty: one axis.
    std::vector<std::string> axes;
};
// `scenario`: the console's --scenario ("" without): the simulator needs it.
CommissionForm parse_commission_form(const nlohmann::json& j, const std::string& scenario);

// commission's messages at the form's fields ("--range-um: ..." -> range_um).
FieldRefusal commission_refusal(const std::string& message);

// Checks the form (FieldRefusal, before anything moves) and returns the
// work; commission's own checks (a range beyond the travel) come in the
// work, before its first step moves the stage.
MeasurementJob::Work commission_work(BoardSession& board, const std::string& scenario, const nlohmann::json& form);

// The figures a result may name (frf.png, loops.png, candidates.png,
// verification.png; AXIS/frf.png ... for a stage of axes): the file's path
// in its directory, "" for any other name or no result.
std::string commission_figure_path(const nlohmann::json& result, const std::string& name);

}  // namespace piezoloop::ui
