// `piezoloop design hinf` and `piezoloop design mixsyn`: H∞ synthesis
// (host/synth/, docs/synthesis.md), added to the `design` command of
// cmd_design.cpp.
//
//   design hinf   --plant P.json [--gamma-tol X] [--gamma-max G] [--backoff B] [--out K.json]
//   design mixsyn --plant G.json --w1 W1.json [--w2 W2.json] [--w3 W3.json]
//                 [--gamma-tol X] [--gamma-max G] [--backoff B] [--out K.json]
//
// JSON on stdout. Exit codes (README, 'Exit codes'): 2 for bad input (an
// option out of range, a malformed file, an unstable or improper weight —
// the message names the option, file or field); 1 when the problem has no
// solution or cannot be solved reliably (D12 or D21 rank, stabilisability,
// a zero on the imaginary axis, no γ in the interval, a controller that
// misses its γ) — the message names the condition; nothing on stdout then.
#include <cmath>
#include <fstream>
#include <iostream>
#include <memory>
#include <optional>
#include <string>

#include <nlohmann/json.hpp>

#include "commands.hpp"
#include "lti/lti_convert.hpp"
#include "lti/model_json.hpp"
#include "synth/hinfsyn.hpp"
#include "synth/mixsyn.hpp"
#include "synth/plant_json.hpp"
#include "synth/synth_report.hpp"

namespace piezoloop::cli {
namespace {

using namespace piezoloop::design;
using nlohmann::json;

// The γ-iteration settings (synth/synth_report.hpp) and --out.
struct SynthArgs : SynthSettings {
    std::string out;
};

struct HinfArgs : SynthArgs {
    std::string plant;
};

struct MixsynArgs : SynthArgs {
    std::string plant, w1, w2, w3;
};

void write_model(const std::string& file, json model) {
    std::ofstream f(file);
    if (!f) throw std::runtime_error("--out: cannot write " + file);
    f << model.dump(1) << "\n";
    if (!f) throw std::runtime_error("--out: cannot write " + file);
}

int run_hinf(const HinfArgs& a) {
    (void)hinf_options(a);  // options first, then the file
    const HinfReport rep = hinf_report(load_plant_file(a.plant), a.plant, a);
    const HinfSynthesis& r = rep.result;
    if (!a.out.empty()) {
        json m = state_space_json(r.controller);
        m["description"] = "H∞ central controller from piezoloop design hinf --plant " + a.plant +
                           " (y -> u, continuous, s in rad/s)";
        write_model(a.out, m);
    }
    std::cout << rep.json.dump(1) << "\n";
    return kExitOk;
}

int run_mixsyn(const MixsynArgs& a) {
    (void)hinf_options(a);  // options first, as before the files
    ModelParseOptions improper_ok;
    improper_ok.allow_improper = true;  // so mixsyn names the improper weight itself
    const NamedModel g{load_model_file(a.plant), a.plant};
    const NamedModel w1{load_model_file(a.w1, improper_ok), a.w1};
    std::optional<NamedModel> w2, w3;
    if (!a.w2.empty()) w2 = NamedModel{load_model_file(a.w2, improper_ok), a.w2};
    if (!a.w3.empty()) w3 = NamedModel{load_model_file(a.w3, improper_ok), a.w3};
    const MixsynReport rep = mixsyn_report(g, w1, w2, w3, a);
    const MixsynResult& r = rep.result;
    const json& out = rep.json;
    if (!a.out.empty()) {
        json m = to_json(r.controller_zpk);
        m["description"] = "mixed-sensitivity H∞ controller (e -> u) from piezoloop design mixsyn --plant " + a.plant +
                           " --w1 " + a.w1 + (w2 ? " --w2 " + a.w2 : "") + (w3 ? " --w3 " + a.w3 : "") +
                           "; gamma " + std::to_string(r.gamma);
        write_model(a.out, m);
    }
    std::cout << out.dump(1) << "\n";
    return kExitOk;
}

void add_synth_options(CLI::App* cmd, SynthArgs& a) {
    cmd->add_option("--gamma-tol", a.gamma_tol,
                    "relative tolerance of the γ bisection, [1e-12, 0.1] (default 1e-6)");
    cmd->add_option("--gamma-max", a.gamma_max, "upper end of the γ search (default: 1, 10, ... up to 1e15)");
    cmd->add_option("--backoff", a.backoff,
                    "controller formed at γ_opt (1 + backoff), [0, 1] (default 1e-3: at γ_opt exactly the central "
                    "controller has poles at infinity)");
    cmd->add_option("--out", a.out, "also write the controller as a model file (JSON)");
}

void add_design_synth(CLI::App& app) {
    CLI::App* design = app.get_subcommand("design");

    auto h = std::make_shared<HinfArgs>();
    CLI::App* hinf = design->add_subcommand(
        "hinf",
        "H∞ output-feedback synthesis (γ iteration, central controller) for a generalised plant. Plant file: "
        "{\"A\": rows, \"B\": rows, \"C\": rows, \"D\": rows, \"partition\": {\"w\": nw, \"u\": nu, \"z\": nz, "
        "\"y\": ny}}, inputs [w; u], outputs [z; y], continuous (docs/synthesis.md). Prints gamma (achieved), "
        "the controller (A, B, C, D; y -> u) and the Riccati diagnostics");
    hinf->add_option("--plant", h->plant, "generalised plant file (JSON, see above)")->required();
    add_synth_options(hinf, *h);
    hinf->callback([h] { guarded([&] { return run_hinf(*h); }); });

    auto m = std::make_shared<MixsynArgs>();
    CLI::App* mix = design->add_subcommand(
        "mixsyn",
        "Mixed-sensitivity H∞ design min ||[W1 S; W2 K S; W3 T]||∞ for a SISO plant (model files: num/den, "
        "zeros/poles/gain or series; continuous). Weights must be proper and stable. Prints gamma, controller "
        "(zeros/poles/gain, e -> u), stable, hinf_W1S, hinf_W2KS, hinf_W3T, order");
    mix->add_option("--plant", m->plant, "plant G (model file)")->required();
    mix->add_option("--w1", m->w1, "weight on S (model file)")->required();
    mix->add_option("--w2", m->w2, "weight on K S (model file; needed when G is strictly proper)");
    mix->add_option("--w3", m->w3, "weight on T (model file)");
    add_synth_options(mix, *m);
    mix->callback([m] { guarded([&] { return run_mixsyn(*m); }); });
}

}  // namespace

namespace {
// After `design` (20), which it extends.
const bool registered_design_synth = register_command(21, add_design_synth);
}  // namespace

}  // namespace piezoloop::cli
