// The JSON of `piezoloop design c2d` (and of its filters' realisation):
// a continuous model discretised, split into sections scaled for the
// core's sample type, and the realisation check. Shared by the command
// line (cli/cmd_design.cpp) and the Python module (python/src/design.cpp).
#pragma once

#include <optional>
#include <string>

#include <nlohmann/json.hpp>

#include "lti/lti.hpp"

namespace piezoloop::design {

struct RealiseOptions {
    double rate_hz = 0.0;
    std::string format = "q31";   // float | q31
    std::string scaling = "l1";   // l1 | linf | none
    double in_full_scale = 1.0;
    double out_full_scale = 1.0;
    double headroom = 1.0;
    bool no_check = false;        // skip the realisation check
};

// std::invalid_argument "<field>: <what>" for an option out of range.
void check_realise_options(const RealiseOptions& o);

// Discrete design -> scaled sections -> realisation check, into `out`
// ("format", "sections", "scaling", "realisation", "warnings"). Returns
// false if the realisation is unfit.
bool realise(const Zpk& discrete, const RealiseOptions& o, nlohmann::json& out);

struct C2dReport {
    nlohmann::json json;  // command, model_file, rate_hz, method, continuous, discrete
    Zpk discrete;
};

// The model discretised at rate_hz (method tustin | zoh | matched, Tustin
// optionally pre-warped), or taken as it is when already discrete at that
// rate; std::invalid_argument naming the field otherwise. The caller adds
// the sections with realise().
C2dReport c2d_report(const Zpk& model, const std::string& model_file, double rate_hz, const std::string& method,
                     const std::optional<double>& prewarp_hz);

}  // namespace piezoloop::design
