// `piezoloop commission` as one call, shared by the command line
// (cli/cmd_commission.cpp) and the Python module: the sequence of
// host/commission/commission.hpp on a board or a scenario's stage, the
// result saved on a board when it is verified, and the files of DIR
// (report.md with its figures, controller.json, frf.json, scenario.json).
#pragma once

#include <functional>
#include <string>

#include <nlohmann/json.hpp>

#include "commission/commission.hpp"
#include "link/client.hpp"

namespace piezoloop::cli {

struct CommissionSession {
    std::string scenario;  // the simulator's stage; empty: the board
    std::string axis;      // the axis commissioned, of a scenario's coupled axes or a board's (the others hold)
    std::string out;       // directory for the files
    bool save = true;      // board: save the verified result (`save`)
    commission::CommissionRequest request;
    // Board: each recording's fraction received, as it arrives (may be empty).
    std::function<void(double)> recording_progress;
};

// Runs it on `board` (nullptr: the scenario's stage) and returns the summary
// JSON `piezoloop commission` prints ("verified" says whether it is kept;
// "log" the steps and decisions, "safety" and "fits" the report's tables).
// Each step's line goes to `progress` (may be empty). Throws as commission::commission does, with a board left
// disarmed.
nlohmann::json run_commission_session(hostlink::Client* board, const CommissionSession& s,
                                      const std::function<void(const std::string&)>& progress,
                                      const std::function<bool()>& stop_requested = {});

}  // namespace piezoloop::cli
