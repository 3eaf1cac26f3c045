// What `piezoloop analyze coupling` reports of a measured n x n frequency
// response, as JSON (the command and the Python module print the same):
// per pair the low-frequency and largest coupling (coupling.hpp), the
// static gain G0, its condition, the decoupling output matrix D and the
// coupling left after it (static_decoupling.hpp). Pairs are named
// "y<i><-u<j>" (1-based: output i <- input j); a coupling of exactly zero
// (-inf dB) or unknown is JSON null.
#pragma once

#include <optional>

#include <nlohmann/json.hpp>

#include "measure/mimo_frf_estimate.hpp"

namespace piezoloop::measure {

// Throws std::invalid_argument: "inputs: ..." for fewer than 2 axes,
// "outputs: ..." when outputs != inputs, "below_Hz: ..." for a bad limit,
// "G0 ..." for an ill-conditioned static gain.
nlohmann::json coupling_report(const MimoFrfEstimate& e, std::optional<double> below_Hz);

}  // namespace piezoloop::measure
