// `piezoloop design musyn`: μ-synthesis by D–K iteration (host/synth/
// dk_iteration.hpp, docs/synthesis.md 'D–K iteration'), added to `design`.
//
//   design musyn --plant G.json --w1 We.json --hm Hm.json [--w3 Wy.json] [--w2 Wu.json]
//                [--iterations N] [--d-order K] [--gamma-tol X] [--backoff B] [--out K.json]
//
// Progress per iteration on stderr; JSON on stdout: gamma, controller (model
// object), stable, order, iterations (γ, μ peak, orders, d(s) per K step),
// and rs/np/rp peaks of the returned controller from analysis/mu's mu_loop.
// Exit codes as `design mixsyn`: 2 bad input (naming the option/model), 1
// no solution (naming the condition).
#include <cstdio>
#include <fstream>
#include <iostream>
#include <memory>
#include <numbers>
#include <string>

#include <nlohmann/json.hpp>

#include "commands.hpp"
#include "lti/model_json.hpp"
#include "synth/musyn_report.hpp"

namespace piezoloop::cli {
namespace {

using namespace piezoloop::design;
using nlohmann::json;

struct MusynArgs {
    std::string plant, w1, w2, w3, hm, out;
    MusynSettings settings;
};

Zpk load(const std::string& file, const char* option) {
    ModelParseOptions improper_ok;
    improper_ok.allow_improper = true;  // so the synthesis names the improper weight itself
    try {
        return load_model_file(file, improper_ok);
    } catch (const std::exception& e) {
        throw std::invalid_argument(std::string(option) + ": " + e.what());
    }
}

int run_musyn(const MusynArgs& a) {
    MusynProblem pb;
    pb.plant = load(a.plant, "--plant");
    pb.w1 = load(a.w1, "--w1");
    pb.hm = load(a.hm, "--hm");
    if (!a.w3.empty()) pb.w3 = load(a.w3, "--w3");
    if (!a.w2.empty()) pb.w2 = load(a.w2, "--w2");
    const MusynReport rep = musyn_report(pb, {a.plant, a.w1, a.hm, a.w2, a.w3}, a.settings, [](const DkRecord& r) {
        std::fprintf(stderr, "iteration %d: gamma %.5g  mu peak %.5g at %.4g Hz  (controller order %d, %.2f s)\n",
                     r.iteration, r.gamma, r.mu_peak, r.mu_peak_w_rad_s / (2.0 * std::numbers::pi),
                     r.controller_order, r.seconds);
    });
    const MusynResult& r = rep.result;
    if (!a.out.empty()) {
        json f = to_json(r.controller_zpk);
        f["description"] = "mu-synthesis controller (e -> u) from piezoloop design musyn --plant " + a.plant +
                           " --w1 " + a.w1 + " --hm " + a.hm + (pb.w3 ? " --w3 " + a.w3 : "") +
                           (pb.w2 ? " --w2 " + a.w2 : "") + " --iterations " + std::to_string(a.settings.iterations) +
                           " --d-order " + std::to_string(a.settings.d_order) + "; rp peak " + std::to_string(rep.rp_peak);
        std::ofstream file(a.out);
        if (!(file << f.dump(1) << "\n")) throw std::runtime_error("--out: cannot write " + a.out);
    }
    std::cout << rep.json.dump(1) << "\n";
    return kExitOk;
}

void add_design_musyn(CLI::App& app) {
    CLI::App* design = app.get_subcommand("design");
    auto a = std::make_shared<MusynArgs>();
    CLI::App* c = design->add_subcommand(
        "musyn",
        "μ-synthesis by D–K iteration for G_p = G (1 + Δ H_m), |Δ| <= 1, with performance [W1 e; W3 y; W2 u] "
        "driven by r (docs/synthesis.md). Prints per iteration γ and the μ peak (stderr), then JSON: gamma, "
        "controller (zeros/poles/gain, e -> u), stable, order, iterations, rs/np/rp peaks");
    c->add_option("--plant", a->plant, "plant G (model file)")->required();
    c->add_option("--w1", a->w1, "performance weight on e = r - y (model file)")->required();
    c->add_option("--hm", a->hm, "input multiplicative uncertainty weight H_m (model file)")->required();
    c->add_option("--w3", a->w3, "performance weight on y (model file)");
    c->add_option("--w2", a->w2, "actuator weight on u (model file; needed unless H_m(inf) != 0)");
    c->add_option("--iterations", a->settings.iterations, "K steps at most, [1, 20] (default 4)");
    c->add_option("--d-order", a->settings.d_order, "order of the fitted D scaling, [0, 12] (default 4)");
    c->add_option("--gamma-tol", a->settings.gamma_tol, "relative tolerance of each γ bisection (default 1e-4)");
    c->add_option("--backoff", a->settings.backoff, "controller formed at γ_opt (1 + backoff) (default 1e-3)");
    c->add_option("--out", a->out, "also write the controller as a model file (JSON)");
    c->callback([a] { guarded([&] { return run_musyn(*a); }); });
}

// After `design` (20) and `design hinf|mixsyn` (21).
const bool registered_design_musyn = register_command(22, add_design_musyn);

}  // namespace
}  // namespace piezoloop::cli
