// `piezoloop reproduce`: the report (Markdown, tables laid out like the
// sources' tables) and the figure specifications that tools/plot_sim.py
// draws (generic panels of x-y series, see that script).
#pragma once

#include <filesystem>
#include <string>
#include <vector>

#include <nlohmann/json.hpp>

#include "sim/experiments.hpp"

namespace piezoloop::sim {

struct ReportFigure {
    std::string file;   // relative to the report directory
    nlohmann::json spec;
};

// Markdown section of one scenario; figures to draw are appended to `figures`
// (files under figures/ in the report directory).
std::string scenario_report(const ScenarioResult& r, std::vector<ReportFigure>& figures);

// -3 dB bandwidth (Hz) from a bode experiment's cells of one case: the first
// frequency where |y/r| falls below 1/sqrt(2), interpolated in log f; a
// negative value if it does not fall below in the measured range.
double bandwidth_3db_Hz(const std::vector<const CellResult*>& cells);

}  // namespace piezoloop::sim
