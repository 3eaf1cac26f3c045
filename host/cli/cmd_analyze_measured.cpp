// `piezoloop analyze measured-loop --frf frf.json --controller K.json
// [--error-per-um X] [--c2d tustin|zoh|matched] [--prewarp-hz F]`: a
// controller's loop on the *measured* plant (analysis/measured_loop.hpp):
// margins at the crossings between the measured lines and the sensitivity
// peak over them, so a design is checked on what the stage did, not only on
// its fitted model. The plant is `measure frf`'s u (V) -> y (um); the loop
// L = G · error_per_um · K, as a scenario's feedback scales the error
// (error_per_um, 1/um) before K. A continuous controller is discretised at
// the measurement's loop rate, as a board would run it.
#include <iostream>
#include <memory>
#include <string>

#include <nlohmann/json.hpp>

#include "analysis/loop_report.hpp"
#include "analysis/measured_loop.hpp"
#include "commands.hpp"
#include "lti/model_json.hpp"
#include "measure/frf_file.hpp"

namespace piezoloop::cli {
namespace {

using namespace piezoloop::design;
using nlohmann::json;

struct MeasuredArgs {
    std::string frf, controller;
    double error_per_um = 1.0;
    LoopDiscretise disc;
};

json crossing_json(const std::optional<MeasuredCrossing>& c, const char* value_key) {
    if (!c) return nullptr;
    return {{"f_Hz", c->f_Hz}, {value_key, c->value}};
}

void run_measured(MeasuredArgs a) {
    if (!(a.error_per_um > 0.0) || !std::isfinite(a.error_per_um))
        throw std::invalid_argument("--error-per-um: must be finite and > 0");
    const measure::FrfData d = measure::load_frf_file(a.frf);
    a.disc.rate_hz = d.rate_Hz;
    Zpk k = discretise_model(load_model_file(a.controller), a.disc, "controller", a.controller);
    k.gain *= a.error_per_um;
    const MeasuredLoop m = measured_loop(d.f_Hz, d.response, k);
    json gc = json::array(), pc = json::array();
    for (const MeasuredCrossing& c : m.gain_crossovers) gc.push_back({{"f_Hz", c.f_Hz}, {"phase_margin_deg", c.value}});
    for (const MeasuredCrossing& c : m.phase_crossovers) pc.push_back({{"f_Hz", c.f_Hz}, {"gain_margin_db", c.value}});
    json out;
    out["frf"] = a.frf;
    out["controller"] = a.controller;
    out["rate_Hz"] = d.rate_Hz;
    out["lines"] = d.f_Hz.size();
    out["band_Hz"] = {d.f_Hz.front(), d.f_Hz.back()};
    out["phase_margin"] = crossing_json(m.phase_margin, "phase_margin_deg");
    out["gain_margin"] = crossing_json(m.gain_margin, "gain_margin_db");
    out["gain_crossovers"] = gc;
    out["phase_crossovers"] = pc;
    out["max_sensitivity"] = m.max_sensitivity;
    out["max_sensitivity_db"] = 20.0 * std::log10(m.max_sensitivity);
    out["max_sensitivity_Hz"] = m.max_sensitivity_Hz;
    out["warnings"] = m.warnings;
    out["meaning"] = "L = G (measured lines) x error_per_um x K; margins interpolated between lines on log f; "
                     "max_sensitivity over the lines is a lower bound of ||S||inf";
    std::cout << out.dump(1) << "\n";
}

void add_analyze_measured(CLI::App& app) {
    CLI::App* analyze = app.get_subcommand("analyze");
    auto a = std::make_shared<MeasuredArgs>();
    CLI::App* c = analyze->add_subcommand(
        "measured-loop", "A controller on a measured frequency response (measure frf's JSON): gain and phase "
                         "margins and the sensitivity peak over the measured lines");
    c->add_option("--frf", a->frf, "measured response u (V) -> y (um): piezoloop measure frf --out")->required();
    c->add_option("--controller", a->controller, "controller model file K (JSON), continuous or at the FRF's rate")
        ->required();
    c->add_option("--error-per-um", a->error_per_um, "the error's scale before K (a scenario's feedback error_per_um)")
        ->capture_default_str();
    c->add_option("--c2d", a->disc.method, "discretisation of a continuous controller at the FRF's rate")
        ->check(CLI::IsMember({"tustin", "zoh", "matched"}))
        ->capture_default_str();
    c->add_option("--prewarp-hz", a->disc.prewarp_hz, "Tustin pre-warp frequency (Hz)")->check(CLI::NonNegativeNumber);
    c->callback([a] { guarded([&] { run_measured(*a); }); });
}

// After `analyze` (30) and `analyze mu` (31).
const bool registered_analyze_measured = register_command(32, add_analyze_measured);

}  // namespace
}  // namespace piezoloop::cli
