// `piezoloop analyze mu`'s JSON: the robust stability, nominal and robust
// performance peaks of a loop (mu.hpp's mu_loop) with their frequencies and
// what passes. Shared by the command line (cli/cmd_analyze_mu.cpp) and the
// Python module (python/src/design.cpp).
#pragma once

#include <nlohmann/json.hpp>

#include "analysis/mu.hpp"

namespace piezoloop::design {

struct MuReport {
    nlohmann::json json;
    MuLoopResult result;
};

// Throws std::invalid_argument naming the model whose ts differs from the
// plant's (all continuous, or all discrete with one ts).
MuReport mu_report(const MuLoopModels& m);

}  // namespace piezoloop::design
