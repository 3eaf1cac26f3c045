// The JSON of `piezoloop analyze loop`: stability, closed-loop poles, H-inf
// norms of S, T, KS, GS and of the weighted maps, robust stability against
// H_m with the coefficient family, bandwidth, margins and phase lags.
// Shared by the command line (cli/cmd_analyze.cpp, which adds the plot) and
// the Python module (python/src/design.cpp), which give models as files or
// as dicts.
#pragma once

#include <optional>
#include <string>
#include <vector>

#include <nlohmann/json.hpp>

#include "analysis/analysis.hpp"
#include "lti/lti.hpp"

namespace piezoloop::design {

// How continuous models are discretised (`--rate-hz`, `--c2d`,
// `--plant-c2d`, `--prewarp-hz`); rate_hz 0: they are used as given.
struct LoopDiscretise {
    double rate_hz = 0.0;
    std::string method = "tustin";
    std::string plant_method;  // empty: as `method`
    double prewarp_hz = 0.0;
};

// With a rate, a continuous model is discretised and a discrete one must
// already have ts = 1/rate (std::invalid_argument naming `what` and `name`).
Zpk discretise_model(const Zpk& m, const LoopDiscretise& d, const std::string& what, const std::string& name,
                     bool is_plant = false);

// The models as given (continuous or discrete); the names label messages.
struct LoopModels {
    Zpk plant, controller;
    std::optional<Zpk> we, wy, hm;  // weights on S and T, multiplicative uncertainty
    std::string plant_name = "plant", controller_name = "controller", we_name = "we", wy_name = "wy",
                hm_name = "hm";
};

struct LoopReportOptions {
    LoopDiscretise disc;
    std::vector<double> phase_lag_hz;  // phase lag of T at these frequencies
    double family_rel = 0.05;          // coefficient family: relative perturbation
    bool family = true;                // with hm: check the coefficient family
};

struct LoopReport {
    nlohmann::json json;
    Zpk plant, controller;           // as analysed (discretised)
    std::optional<Zpk> we, wy, hm;   // likewise
    Margins margins;
};

LoopReport loop_report(const LoopModels& models, const LoopReportOptions& options);

// JSON helpers the analysis reports share: a non-finite number as null,
// rad/s as Hz, roots as [re, im] pairs, an H-inf result.
nlohmann::json report_number(double v);
nlohmann::json report_hz(double w_rad_s);
nlohmann::json roots_json(const std::vector<cplx>& r);
nlohmann::json hinf_json(const HinfResult& h, bool loop_stable);

}  // namespace piezoloop::design
