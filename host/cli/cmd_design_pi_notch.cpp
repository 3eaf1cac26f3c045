// `piezoloop design pi-notch --plant G.json --crossover-hz F [--pm-min-deg 45]
// [--gm-min-db 6] [--out K.json]`: the classic candidate of a commissioning
// (synth/pi_notch.hpp): PI plus notches at the plant's lightly damped
// resonances above crossover, tuned to the crossover and lowered until the
// margins hold. JSON on stdout: controller (zeros/poles/gain, e -> u), kp,
// integral_Hz, target_Hz, crossover_Hz, notches, phase_margin_deg,
// gain_margin_db (null: infinite), hinf_S, warnings. Exit 2 for bad input
// or when no crossover meets the margins (naming the option).
#include <fstream>
#include <iostream>
#include <memory>
#include <string>

#include <nlohmann/json.hpp>

#include "commands.hpp"
#include "lti/model_json.hpp"
#include "synth/synth_report.hpp"

namespace piezoloop::cli {
namespace {

using namespace piezoloop::design;
using nlohmann::json;

struct PiNotchArgs {
    std::string plant, out;
    double crossover_Hz = 0.0;
    PiNotchOptions options;
};

void run_pi_notch(const PiNotchArgs& a) {
    const PiNotchDesign d = design_pi_notch(load_model_file(a.plant), a.crossover_Hz, a.options);
    json out = pi_notch_json(d);
    out["command"] = "pi-notch";
    out["plant_file"] = a.plant;
    if (!a.out.empty()) {
        json m = to_json(d.controller);
        m["description"] = "PI + notches from piezoloop design pi-notch --plant " + a.plant + " --crossover-hz " +
                           std::to_string(a.crossover_Hz) + ": crossover " + std::to_string(d.crossover_Hz) +
                           " Hz, PM " + std::to_string(d.phase_margin_deg) + " deg";
        std::ofstream f(a.out);
        if (!(f << m.dump(1) << "\n")) throw std::runtime_error("--out: cannot write " + a.out);
    }
    std::cout << out.dump(1) << "\n";
}

void add_design_pi_notch(CLI::App& app) {
    CLI::App* design = app.get_subcommand("design");
    auto a = std::make_shared<PiNotchArgs>();
    CLI::App* c = design->add_subcommand(
        "pi-notch", "PI plus notches at the plant's lightly damped resonances above crossover, tuned to a target "
                    "crossover and lowered until PM and GM hold (docs/synthesis.md, 'PI + notches')");
    c->add_option("--plant", a->plant, "plant G (model file, continuous)")->required();
    c->add_option("--crossover-hz", a->crossover_Hz, "target gain crossover (Hz)")->required();
    c->add_option("--pm-min-deg", a->options.pm_min_deg, "smallest phase margin (deg)")->capture_default_str();
    c->add_option("--gm-min-db", a->options.gm_min_db, "smallest gain margin (dB)")->capture_default_str();
    c->add_option("--out", a->out, "also write the controller as a model file (JSON)");
    c->callback([a] { guarded([&] { run_pi_notch(*a); }); });
}

// After `design` (20), `design hinf|mixsyn` (21) and `design musyn` (22).
const bool registered_design_pi_notch = register_command(23, add_design_pi_notch);

}  // namespace
}  // namespace piezoloop::cli
