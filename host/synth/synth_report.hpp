// The JSON of `piezoloop design hinf|mixsyn|pi-notch`: the γ-iteration
// settings, the synthesis figures, the mixed-sensitivity report and the
// PI + notches design. Shared by the command
// line (cli/cmd_design_synth.cpp) and the Python module (python/src/design.cpp).
#pragma once

#include <optional>
#include <string>

#include <nlohmann/json.hpp>

#include "lti/lti.hpp"
#include "synth/hinfsyn.hpp"
#include "synth/mixsyn.hpp"
#include "synth/pi_notch.hpp"

namespace piezoloop::design {

struct SynthSettings {
    double gamma_tol = 1e-6;  // relative tolerance of the γ bisection
    double gamma_max = 0.0;   // 0: found by the synthesis
    double backoff = 1e-3;    // relative γ above the optimum the controller is built for
};

// std::invalid_argument naming the option (--gamma-tol, ...) out of range.
HinfOptions hinf_options(const SynthSettings& s);

nlohmann::json synthesis_json(const HinfSynthesis& r, const SynthSettings& s);

struct HinfReport {
    nlohmann::json json;
    HinfSynthesis result;
};

// `design hinf`: gamma, stable, order, synthesis, controller (state space)
// and, for a SISO controller, controller_model (zeros/poles/gain).
HinfReport hinf_report(const GeneralisedPlant& p, const std::string& plant_name, const SynthSettings& s);

// A weight or plant and the name it is reported by (its file, or a label).
struct NamedModel {
    Zpk model;
    std::string name;
};

struct MixsynReport {
    nlohmann::json json;
    MixsynResult result;
};

MixsynReport mixsyn_report(const NamedModel& plant, const NamedModel& w1, const std::optional<NamedModel>& w2,
                           const std::optional<NamedModel>& w3, const SynthSettings& s);

// controller (zeros/poles/gain), kp, integral_Hz, target_Hz, crossover_Hz,
// notches, phase_margin_deg, gain_margin_db (null: infinite), hinf_S, warnings.
nlohmann::json pi_notch_json(const PiNotchDesign& d);

}  // namespace piezoloop::design
