// `piezoloop reduce`'s JSON: balanced truncation (balred.hpp) of a stable
// model to an order, with the Hankel singular values and the H∞ error bound.
// Shared by the command line (cli/cmd_identify.cpp) and the Python module.
#pragma once

#include <nlohmann/json.hpp>

#include "lti/lti.hpp"

namespace piezoloop::design {

// model (zeros/poles/gain), order, original_order, hsv, error_bound.
nlohmann::json reduce_report(const Zpk& full, int order);

}  // namespace piezoloop::design
