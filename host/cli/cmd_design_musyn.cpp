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
#include <chrono>
#include <cstdio>
#include <fstream>
#include <iostream>
#include <memory>
#include <numbers>
#include <string>

#include <nlohmann/json.hpp>

#include "analysis/loop_report.hpp"
#include "analysis/mu.hpp"
#include "commands.hpp"
#include "lti/model_json.hpp"
#include "synth/dk_iteration.hpp"
#include "synth/plant_json.hpp"

namespace piezoloop::cli {
namespace {

using namespace piezoloop::design;
using nlohmann::json;

constexpr double kTwoPi = 2.0 * std::numbers::pi;

json number(double v) { return report_number(v); }

struct MusynArgs {
    std::string plant, w1, w2, w3, hm, out;
    int iterations = 4, d_order = 4;
    double gamma_tol = 1e-4, backoff = 1e-3;
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

json peak_json(const MuPeak& p) {
    return {{"value", number(p.value)}, {"w_rad_s", number(p.w_rad_s)}, {"hz", number(p.w_rad_s / kTwoPi)}};
}

int run_musyn(const MusynArgs& a) {
    if (a.iterations < 1 || a.iterations > 20) throw std::invalid_argument("--iterations: must be in [1, 20]");
    if (a.d_order < 0 || a.d_order > 12) throw std::invalid_argument("--d-order: must be in [0, 12]");
    if (!(a.gamma_tol >= 1e-12 && a.gamma_tol <= 0.1)) throw std::invalid_argument("--gamma-tol: must be in [1e-12, 0.1]");
    if (!(a.backoff >= 0.0 && a.backoff <= 1.0)) throw std::invalid_argument("--backoff: must be in [0, 1]");
    const auto t0 = std::chrono::steady_clock::now();
    MusynProblem pb;
    pb.plant = load(a.plant, "--plant");
    pb.w1 = load(a.w1, "--w1");
    pb.hm = load(a.hm, "--hm");
    if (!a.w3.empty()) pb.w3 = load(a.w3, "--w3");
    if (!a.w2.empty()) pb.w2 = load(a.w2, "--w2");
    MusynOptions o;
    o.iterations = a.iterations;
    o.d_order = a.d_order;
    o.hinf.rel_tol = a.gamma_tol;
    o.hinf.backoff = a.backoff;
    o.on_iteration = [](const DkRecord& r) {
        std::fprintf(stderr, "iteration %d: gamma %.5g  mu peak %.5g at %.4g Hz  (controller order %d, %.2f s)\n",
                     r.iteration, r.gamma, r.mu_peak, r.mu_peak_w_rad_s / kTwoPi, r.controller_order, r.seconds);
    };
    const MusynResult r = musyn(pb, o);
    MuLoopModels m;
    m.plant = pb.plant;
    m.controller = r.controller_zpk;
    m.hm = pb.hm;
    m.w1 = pb.w1;
    m.has_w3 = pb.w3.has_value();
    if (pb.w3) m.w3 = *pb.w3;
    m.has_w2 = pb.w2.has_value();
    if (pb.w2) m.w2 = *pb.w2;
    const MuLoopResult mu = mu_loop(m);
    const double seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();

    json its = json::array();
    for (const DkRecord& k : r.records)
        its.push_back({{"iteration", k.iteration},
                       {"gamma", number(k.gamma)},
                       {"mu_peak", number(k.mu_peak)},
                       {"mu_peak_hz", number(k.mu_peak_w_rad_s / kTwoPi)},
                       {"controller_order", k.controller_order},
                       {"plant_order", k.plant_order},
                       {"d_scaling", to_json(k.d_used)},
                       {"d_fit_max_rel_error", k.d_fit_max_rel_error},
                       {"seconds", k.seconds}});
    json out;
    out["command"] = "musyn";
    out["plant_file"] = a.plant;
    out["weights"] = {{"w1", a.w1}, {"hm", a.hm}, {"w2", pb.w2 ? json(a.w2) : json(nullptr)},
                      {"w3", pb.w3 ? json(a.w3) : json(nullptr)}};
    out["gamma"] = r.gamma;
    out["stable"] = r.stable && mu.nominally_stable;
    out["order"] = r.order;
    out["plant_order"] = r.plant_order;
    out["best_iteration"] = r.records[static_cast<std::size_t>(r.best)].iteration;
    out["stop_reason"] = r.stop_reason;
    out["iterations"] = its;
    out["rs_peak"] = peak_json(mu.rs);
    out["np_peak"] = peak_json(mu.np);
    out["rp_peak"] = peak_json(mu.rp);
    out["rp_peak_lower"] = number(mu.rp.lower);
    out["seconds"] = seconds;
    out["controller"] = to_json(r.controller_zpk);
    out["controller_ss"] = state_space_json(r.controller);
    if (!a.out.empty()) {
        json f = to_json(r.controller_zpk);
        f["description"] = "mu-synthesis controller (e -> u) from piezoloop design musyn --plant " + a.plant +
                           " --w1 " + a.w1 + " --hm " + a.hm + (pb.w3 ? " --w3 " + a.w3 : "") +
                           (pb.w2 ? " --w2 " + a.w2 : "") + " --iterations " + std::to_string(a.iterations) +
                           " --d-order " + std::to_string(a.d_order) + "; rp peak " + std::to_string(mu.rp.value);
        std::ofstream file(a.out);
        if (!(file << f.dump(1) << "\n")) throw std::runtime_error("--out: cannot write " + a.out);
    }
    std::cout << out.dump(1) << "\n";
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
    c->add_option("--iterations", a->iterations, "K steps at most, [1, 20] (default 4)");
    c->add_option("--d-order", a->d_order, "order of the fitted D scaling, [0, 12] (default 4)");
    c->add_option("--gamma-tol", a->gamma_tol, "relative tolerance of each γ bisection (default 1e-4)");
    c->add_option("--backoff", a->backoff, "controller formed at γ_opt (1 + backoff) (default 1e-3)");
    c->add_option("--out", a->out, "also write the controller as a model file (JSON)");
    c->callback([a] { guarded([&] { return run_musyn(*a); }); });
}

// After `design` (20) and `design hinf|mixsyn` (21).
const bool registered = register_command(22, add_design_musyn);

}  // namespace
}  // namespace piezoloop::cli
