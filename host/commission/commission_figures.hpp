// The commissioning report's figures as tools/plot_sim.py specs (one figure
// per entry, each with its "output" PNG in `dir`): the measured response
// beside the chosen fit, the hysteresis loop beside the PI model, the
// candidates' loop and sensitivity on the measured lines, and the
// verification's tracking beside its prediction.
#pragma once

#include <filesystem>

#include <nlohmann/json.hpp>

#include "commission/commission.hpp"

namespace piezoloop::commission {

nlohmann::json commission_figures(const Commissioning& c, const std::filesystem::path& dir);

}  // namespace piezoloop::commission
