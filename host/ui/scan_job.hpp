// The console's scan: the form's request checked and planned as
// `piezoloop --device ADDR scan` checks and plans it (scan_on_board: the
// same defaults, checks and messages, refused at the form's fields), run on
// the board (BoardSession::scan) as a MeasurementJob, and the result every
// page is sent: the figures `piezoloop scan` prints and the four images
// (commanded and measured positions, x and y error maps).
#pragma once

#include <string>

#include <nlohmann/json.hpp>

#include "ui/board_session.hpp"
#include "ui/measurement_job.hpp"

namespace piezoloop::ui {

// {pattern, size_um: [W, H], pixels: [NX, NY], line_rate_Hz, frames,
// sample, centre_um: [X, Y] | null, restart_stage}. The scenario the
// console was started with (may be empty) is the stage the board drives:
// its travel bounds the scan and gives the default centre. Throws
// FieldRefusal (or BoardBusy) before anything moves.
MeasurementJob::Work scan_work(BoardSession& board, const std::string& scenario, const nlohmann::json& form);

}  // namespace piezoloop::ui
