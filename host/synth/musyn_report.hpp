// `piezoloop design musyn`'s JSON: the D–K iteration (dk_iteration.hpp) with
// its settings checked, and the rs/np/rp peaks of the returned controller
// (analysis/mu.hpp's mu_loop). Shared by the command line
// (cli/cmd_design_musyn.cpp) and the Python module (python/src/design.cpp).
#pragma once

#include <functional>
#include <string>

#include <nlohmann/json.hpp>

#include "synth/dk_iteration.hpp"

namespace piezoloop::design {

struct MusynSettings {
    int iterations = 4;       // K steps at most, [1, 20]
    int d_order = 4;          // order of the fitted D scaling, [0, 12]
    double gamma_tol = 1e-4;  // relative tolerance of each γ bisection
    double backoff = 1e-3;    // controller formed at γ_opt (1 + backoff)
};

// What the models are called in the report (file names or labels); "" for
// an absent weight.
struct MusynNames {
    std::string plant, w1, hm, w2, w3;
};

struct MusynReport {
    nlohmann::json json;
    MusynResult result;
    double rp_peak = 0.0;  // μ upper bound's peak of the returned controller
};

// Throws std::invalid_argument naming the option (--iterations, --d-order,
// --gamma-tol, --backoff) out of range; the synthesis' own errors name the
// failing condition. on_iteration is called after each K step.
MusynReport musyn_report(const MusynProblem& pb, const MusynNames& names, const MusynSettings& s,
                         const std::function<void(const DkRecord&)>& on_iteration = {});

}  // namespace piezoloop::design
