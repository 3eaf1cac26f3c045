// `piezoloop analyze`: loop, repetitive-control and PI-composition analysis
// (docs/models.md) on model files (lti/model_json.hpp).
//
//   analyze loop --plant P.json --controller K.json [--we We.json]
//                [--wy Wy.json] [--hm Hm.json] [--rate-hz F]
//                [--c2d tustin|zoh|matched] [--plant-c2d …] [--prewarp-hz F]
//                [--phase-lag-hz f1,f2,…] [--family-rel 0.05 | --no-family]
//                [--plot FILE.png]
//   analyze rc   (--closed-loop T.json | --loop-plant P.json --controller K.json)
//                --q Q.json --krc k --m1 m --m2 m --period-samples N
//                [--rate-hz F] [--c2d …] [--plant-c2d …] [--pi-g0 g
//                --pi-density d1,d2,… [--pi-spacing rho] | --pi-shan2012]
//                [--plot FILE.png]
//   analyze pi   --model P.json (--estimate E.json | --inverse I.json)
//                [--max-input V] [--plot FILE.png]
//   analyze mu   (cmd_analyze_mu.cpp, added to this subcommand; docs/mu.md)
//
// With --rate-hz, continuous models are discretised (Tustin by default; a
// Tustin loop has exactly the continuous margins and norms on a warped
// frequency axis, --plant-c2d zoh models the sampled plant instead).
// JSON on stdout. Bad input: "error: <field>: <what>" on stderr, exit code
// 2, nothing on stdout. --plot draws the curves with tools/plot.py
// (sim/plotting.hpp).
#include <unistd.h>

#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <fstream>
#include <iostream>
#include <memory>
#include <numbers>
#include <optional>
#include <sstream>
#include <string>
#include <vector>

#include <nlohmann/json.hpp>

#include "commands.hpp"
#include "analysis/analysis.hpp"
#include "analysis/hinf.hpp"
#include "analysis/loop_report.hpp"
#include "analysis/margins.hpp"
#include "analysis/pi_composition.hpp"
#include "analysis/rc_analysis.hpp"
#include "analysis/robust.hpp"
#include "json/json_reader.hpp"
#include "lti/c2d.hpp"
#include "lti/freqresp.hpp"
#include "lti/lti_convert.hpp"
#include "lti/model_json.hpp"
#include "piezoloop/pi_generalized.hpp"
#include "piezoloop/pi_inverse.hpp"
#include "sim/plotting.hpp"
#include "status_text.hpp"
#include "numeric_constants.hpp"

namespace piezoloop::cli {
namespace {

using namespace piezoloop::design;
using nlohmann::json;


// ------------------------------------------------------------- plotting

void plot(const json& spec, const std::string& png) { sim::plot_spec("plot.py", spec, {png}); }

json series_json(const std::string& label, const std::vector<double>& x, const std::vector<double>& y,
                 const std::string& style = "-") {
    json xs = json::array(), ys = json::array();
    for (std::size_t i = 0; i < x.size(); ++i) {
        if (!std::isfinite(y[i])) continue;
        xs.push_back(x[i]);
        ys.push_back(y[i]);
    }
    return {{"label", label}, {"x", xs}, {"y", ys}, {"style", style}};
}

// ------------------------------------------------------------- models

using Discretise = LoopDiscretise;

void add_discretise(CLI::App* cmd, Discretise& d) {
    cmd->add_option("--rate-hz", d.rate_hz, "discretise continuous models at this rate (Hz)")
        ->check(CLI::PositiveNumber);
    cmd->add_option("--c2d", d.method, "discretisation of continuous models")
        ->check(CLI::IsMember({"tustin", "zoh", "matched"}))
        ->capture_default_str();
    cmd->add_option("--plant-c2d", d.plant_method,
                    "discretisation of a continuous plant (default: as --c2d; zoh models the sampled plant)")
        ->check(CLI::IsMember({"tustin", "zoh", "matched"}));
    cmd->add_option("--prewarp-hz", d.prewarp_hz, "Tustin pre-warp frequency (Hz)")->check(CLI::NonNegativeNumber);
}

// Loads a model; with a rate, a continuous model is discretised and a
// discrete one must already have ts = 1/rate.
Zpk load(const std::string& file, const Discretise& d, const char* what, bool is_plant = false) {
    return discretise_model(load_model_file(file), d, what, file, is_plant);
}

std::vector<double> parse_list(const std::string& text, const char* field) {
    std::vector<double> v;
    std::stringstream ss(text);
    std::string item;
    while (std::getline(ss, item, ',')) {
        std::size_t used = 0;
        double x = 0.0;
        try {
            x = std::stod(item, &used);
        } catch (const std::exception&) {
            used = 0;
        }
        if (used == 0 || item.find_first_not_of(" \t", used) != std::string::npos || !std::isfinite(x))
            throw std::invalid_argument(std::string(field) + ": '" + item + "' is not a finite number");
        v.push_back(x);
    }
    if (v.empty()) throw std::invalid_argument(std::string(field) + ": empty list");
    return v;
}

// ------------------------------------------------------------- loop

struct LoopArgs {
    std::string plant, controller, we, wy, hm;
    Discretise disc;
    std::string phase_lag_hz;
    double family_rel = 0.05;
    bool no_family = false;
    std::string plot_file;
};

void run_loop(const LoopArgs& a) {
    LoopModels models;
    models.plant = load_model_file(a.plant);
    models.plant_name = a.plant;
    models.controller = load_model_file(a.controller);
    models.controller_name = a.controller;
    if (!a.we.empty()) models.we = load_model_file(a.we), models.we_name = a.we;
    if (!a.wy.empty()) models.wy = load_model_file(a.wy), models.wy_name = a.wy;
    if (!a.hm.empty()) models.hm = load_model_file(a.hm), models.hm_name = a.hm;
    LoopReportOptions o;
    o.disc = a.disc;
    if (!a.phase_lag_hz.empty()) o.phase_lag_hz = parse_list(a.phase_lag_hz, "phase-lag-hz");
    o.family_rel = a.family_rel;
    o.family = !a.no_family;
    LoopReport rep = loop_report(models, o);
    json& out = rep.json;
    const Zpk& p = rep.plant;
    const Zpk& k = rep.controller;
    const std::optional<Zpk>& we = rep.we;
    const std::optional<Zpk>& wy = rep.wy;
    const std::optional<Zpk>& hm = rep.hm;
    const FeedbackLoop f = feedback_loop(zpk2ss(p), zpk2ss(k));
    const Margins& m = rep.margins;

    if (!a.plot_file.empty()) {
        std::vector<cplx> crit = critical_points(p, k);
        const std::vector<double> w = analysis_grid(crit, p.ts);
        std::vector<double> fhz, lm, lp, sm, tm;
        const SsEvaluator el(series(zpk2ss(k), zpk2ss(p))), es(f.S), et(f.T);
        const FrequencySamples ls = sample_response(el, w);
        for (std::size_t i = 0; i < ls.w.size(); ++i) {
            fhz.push_back(ls.w[i] / kTwoPi);
            lm.push_back(magnitude_db(ls.h[i]));
            lp.push_back(ls.phase[i] * 180.0 / std::numbers::pi);
            sm.push_back(magnitude_db(es.at_w(ls.w[i])));
            tm.push_back(magnitude_db(et.at_w(ls.w[i])));
        }
        json mag = {{"title", "Loop L = PK, sensitivity S, complementary sensitivity T"},
                    {"xlabel", "frequency (Hz)"}, {"ylabel", "magnitude (dB)"}, {"xscale", "log"},
                    {"series", {series_json("|L|", fhz, lm), series_json("|S|", fhz, sm), series_json("|T|", fhz, tm)}},
                    {"hlines", {{{"y", 0.0}, {"label", "0 dB"}}}}};
        for (const auto& [wt, name] : {std::pair{we, "1/|We|"}, std::pair{wy, "1/|Wy|"}, std::pair{hm, "1/|Hm|"}}) {
            if (!wt) continue;
            std::vector<double> v;
            for (double x : ls.w) v.push_back(-magnitude_db(evaluate(*wt, frequency_point(x, p.ts))));
            mag["series"].push_back(series_json(name, fhz, v, "--"));
        }
        json ph = {{"title", "Phase of L"}, {"xlabel", "frequency (Hz)"}, {"ylabel", "phase (deg)"},
                   {"xscale", "log"}, {"series", {series_json("arg L", fhz, lp)}},
                   {"hlines", {{{"y", -180.0}, {"label", "-180 deg"}}}}};
        json vl = json::array();
        if (m.gain_margin) vl.push_back({{"x", m.gain_margin->w_rad_s / kTwoPi}, {"label", "phase crossover"}});
        if (m.phase_margin) vl.push_back({{"x", m.phase_margin->w_rad_s / kTwoPi}, {"label", "gain crossover"}});
        mag["vlines"] = vl;
        ph["vlines"] = vl;
        plot({{"title", "piezoloop analyze loop: " + a.plant + " with " + a.controller}, {"panels", {mag, ph}}},
             a.plot_file);
        out["plot"] = a.plot_file;
    }
    std::cout << out.dump(1) << "\n";
}

// ------------------------------------------------------------- rc

struct RcArgs {
    std::string closed_loop, plant, controller, q;
    Discretise disc;
    double k_rc = 0.0;
    int m1 = 0, m2 = 0, period = 0;
    std::optional<double> pi_g0;
    std::string pi_density;
    double pi_spacing = 0.0;
    bool pi_shan = false;
    std::string plot_file;
};

void run_rc(const RcArgs& a) {
    if (a.closed_loop.empty() == (a.plant.empty() || a.controller.empty()))
        throw std::invalid_argument("closed-loop: give either --closed-loop T.json or --loop-plant and --controller");
    if (!a.closed_loop.empty() && (!a.plant.empty() || !a.controller.empty()))
        throw std::invalid_argument("closed-loop: --closed-loop excludes --loop-plant/--controller");
    RcConfig rc;
    rc.period_samples = a.period;
    rc.m1 = a.m1;
    rc.m2 = a.m2;
    rc.k_rc = a.k_rc;
    rc.q = load(a.q, a.disc, "q");
    if (!is_discrete(rc.q.ts)) throw std::invalid_argument("q: Q must be discrete (or give --rate-hz)");
    std::optional<PiHysteresis> pi;
    if (a.pi_shan) {
        if (a.pi_g0 || !a.pi_density.empty())
            throw std::invalid_argument("pi-shan2012: excludes --pi-g0/--pi-density");
        PiModel m;
        if (const Status s = shan_forward_model(kShan2012Forward, m); !s.ok())
            throw std::invalid_argument("pi-shan2012: " + describe(s));
        if (a.pi_spacing > 0.0) throw std::invalid_argument("pi-shan2012: excludes --pi-spacing");
        pi = PiHysteresis{kShan2012Forward.g0, {}, kShan2012Forward.rho};
        for (int j = 0; j < m.count; ++j) pi->density.push_back(m.weights[static_cast<std::size_t>(j)]);
    } else if (a.pi_g0 || !a.pi_density.empty()) {
        if (!a.pi_g0) throw std::invalid_argument("pi-g0: required with --pi-density");
        pi = PiHysteresis{*a.pi_g0, a.pi_density.empty() ? std::vector<double>{} : parse_list(a.pi_density, "pi-density"),
                          a.pi_spacing};
    }
    RcAnalysis r;
    Ss t, l;
    if (!a.closed_loop.empty()) {
        const Zpk tz = load(a.closed_loop, a.disc, "closed-loop");
        if (tz.ts != rc.q.ts) throw std::invalid_argument("closed-loop: T and Q must share ts");
        t = zpk2ss(tz);
        r = analyze_rc_closed_loop(t, rc, pi);
    } else {
        const Zpk p = load(a.plant, a.disc, "loop-plant", true);
        const Zpk k = load(a.controller, a.disc, "controller");
        if (p.ts != rc.q.ts || k.ts != rc.q.ts)
            throw std::invalid_argument("loop-plant: plant, controller and Q must share ts (give --rate-hz)");
        l = series(zpk2ss(k), zpk2ss(p));
        r = analyze_rc_loop_gain(l, rc, pi);
        t = feedback_loop(zpk2ss(p), zpk2ss(k)).T;
    }
    json out;
    out["ts"] = r.ts;
    out["rc"] = {{"period_samples", rc.period_samples}, {"m1", rc.m1}, {"m2", rc.m2}, {"k_rc", rc.k_rc}};
    out["loop_stable"] = r.loop_stable;
    out["q_cutoff_hz"] = r.q_cutoff_Hz;
    out["condition_3_phase"] = {{"ok", r.phase_ok},
                                {"max_abs_phase_deg", r.max_phase_deg},
                                {"at_Hz", r.max_phase_at_Hz},
                                {"limit_deg", 90.0},
                                {"excess_deg", std::max(0.0, r.max_phase_deg - 90.0)}};
    out["phase_90_at_hz"] = r.phase_90_at_Hz ? json(*r.phase_90_at_Hz) : json(nullptr);
    out["condition_2_gain"] = {{"ok", r.gain_ok},
                               {"k_rc", rc.k_rc},
                               {"k_rc_max", r.k_rc_max},
                               {"at_Hz", r.k_rc_max_at_Hz},
                               {"excess", std::max(0.0, rc.k_rc - r.k_rc_max)}};
    out["condition_1_small_gain"] = {{"ok", r.small_gain_ok},
                                     {"peak", r.small_gain_peak},
                                     {"at_Hz", r.small_gain_at_Hz},
                                     {"meaning", "sup |Q| |1 - k_rc z^m2 T| over 0..Nyquist, must be < 1"}};
    out["exact"] = {{"stable", r.rc_stable ? json(*r.rc_stable) : json(nullptr)},
                    {"max_abs_root", r.rc_max_abs_root ? report_number(*r.rc_max_abs_root) : json(nullptr)},
                    {"meaning", "largest |z| of the roots of 1 - Q z^(m1-N) (1 - k_rc z^m2 T)"}};
    if (r.has_hysteresis) {
        out["hysteresis"] = {
            {"g0", r.g0},
            {"condition_15", {{"ok", r.g0_ok && r.g0_loop_stable},
                              {"gain_margin_rc", r.gain_margin_rc ? report_number(*r.gain_margin_rc) : json(nullptr)},
                              {"at_Hz", r.gain_margin_rc_at_Hz ? report_number(*r.gain_margin_rc_at_Hz) : json(nullptr)},
                              {"g0_loop_stable", r.g0_loop_stable}}},
            {"condition_21", {{"ok", r.density_ok},
                              {"density_l1", r.density_l1},
                              {"density_integral", r.density_integral > 0.0 ? json(r.density_integral) : json(nullptr)},
                              {"integral_ok", r.density_integral > 0.0
                                                  ? json(r.g0_loop_stable && r.density_integral < r.density_bound)
                                                  : json(nullptr)},
                              {"bound", report_number(r.density_bound)},
                              {"hinf_G2", report_number(r.hinf_G2)},
                              {"at_Hz", report_number(r.hinf_G2_at_Hz)},
                              {"method", r.hinf_G2_method},
                              {"ratio", report_number(r.density_l1 / r.density_bound)}}},
            {"inverse_feedforward_required", !r.density_ok}};
    }
    out["ok"] = r.failures.empty();
    out["failures"] = r.failures;

    if (!a.plot_file.empty()) {
        const SsEvaluator et(t);
        const std::vector<double> w = analysis_grid(ss_poles(t), r.ts);
        const FrequencySamples st = sample_response(et, w);
        std::vector<double> f, th, kmax, sg;
        for (std::size_t i = 0; i < st.w.size(); ++i) {
            f.push_back(st.w[i] / kTwoPi);
            const double theta = st.phase[i] + rc.m2 * st.w[i] * r.ts;
            th.push_back(std::abs(theta) * 180.0 / std::numbers::pi);
            kmax.push_back(2.0 * std::cos(theta) / std::abs(st.h[i]));
            sg.push_back(std::abs(evaluate(rc.q, frequency_point(st.w[i], r.ts))) *
                         std::abs(1.0 - rc.k_rc * std::polar(1.0, rc.m2 * st.w[i] * r.ts) * st.h[i]));
        }
        const json vq = {{{"x", r.q_cutoff_Hz}, {"label", "Q cutoff"}}};
        json p1 = {{"title", "(3) |thetaT + theta2|"}, {"xlabel", "frequency (Hz)"}, {"ylabel", "deg"},
                   {"xscale", "log"}, {"series", {series_json("|thetaT + m2 w Ts|", f, th)}},
                   {"hlines", {{{"y", 90.0}, {"label", "90 deg"}}}}, {"vlines", vq}};
        json p2 = {{"title", "(2) 2 cos(theta)/A against k_rc"}, {"xlabel", "frequency (Hz)"}, {"ylabel", ""},
                   {"xscale", "log"}, {"series", {series_json("2 cos(theta)/A", f, kmax)}},
                   {"hlines", {{{"y", rc.k_rc}, {"label", "k_rc"}}}}, {"vlines", vq}, {"ylim", {-1.0, 4.0}}};
        json p3 = {{"title", "(1) |Q| |1 - k_rc z^m2 T|"}, {"xlabel", "frequency (Hz)"}, {"ylabel", ""},
                   {"xscale", "log"}, {"series", {series_json("small-gain", f, sg)}},
                   {"hlines", {{{"y", 1.0}, {"label", "1"}}}}};
        plot({{"title", "piezoloop analyze rc"}, {"panels", {p1, p2, p3}}}, a.plot_file);
        out["plot"] = a.plot_file;
    }
    std::cout << out.dump(1) << "\n";
}

// ------------------------------------------------------------- pi

PiModel load_pi(const std::string& file, const char* what) {
    if (!std::ifstream(file)) throw std::invalid_argument(std::string(what) + ": cannot open " + file);
    json j;
    try {
        j = hostjson::read_file(file);
    } catch (const hostjson::JsonError& e) {
        throw std::invalid_argument(std::string(what) + ": " + e.what());
    }
    const hostjson::Field f(j, what);
    f.only({"thresholds", "weights", "p0"});
    auto list = [&](const char* key) {
        const hostjson::Field a = f[key];
        std::vector<float> v;
        for (std::size_t i = 0; i < a.size(64); ++i) v.push_back(a.at(i).number_f32());
        return v;
    };
    const std::vector<float> r = list("thresholds"), p = list("weights");
    if (r.size() != p.size())
        throw std::invalid_argument(std::string(what) + ".weights: must have as many entries as thresholds");
    std::optional<float> p0;
    if (const auto x = f.get("p0")) p0 = x->number_f32();
    PiModel m;
    if (const Status s = pi_model_from_lists(r.data(), p.data(), static_cast<int>(r.size()), p0 ? &*p0 : nullptr, m);
        !s.ok())
        throw std::invalid_argument(std::string(what) + "." + describe(s));
    return m;
}

struct AnalyzePiArgs {
    std::string model, estimate, inverse, plot_file;
    double max_input = 0.0;
};

void run_pi(const AnalyzePiArgs& a) {
    if (a.estimate.empty() == a.inverse.empty())
        throw std::invalid_argument("estimate: give exactly one of --estimate and --inverse");
    const PiModel p = load_pi(a.model, "model");
    PiModel inv;
    if (!a.estimate.empty()) {
        if (const Status s = invert_pi(load_pi(a.estimate, "estimate"), inv); !s.ok())
            throw std::invalid_argument("estimate." + describe(s));
    } else {
        inv = load_pi(a.inverse, "inverse");
    }
    const PiComposition c = compose_pi(p, inv, a.max_input > 0.0 ? a.max_input : std::numeric_limits<double>::infinity());
    json out;
    out["rho"] = c.rho;
    out["xi_bound"] = c.xi_bound;
    out["p0"] = c.p0;
    out["thresholds"] = c.thresholds;
    out["weights"] = c.weights;
    out["monotone"] = c.monotone;
    if (a.max_input > 0.0) out["max_input"] = a.max_input;
    out["loading_curve"] = {{"v", c.curve_v}, {"eta", c.curve_eta}};
    out["meaning"] = "P[P^-1_est[v]] = rho v + Xi with |Xi| <= xi_bound (docs/models.md, 'Analytic PI inverse')";
    if (!c.monotone) out["warning"] = "eta is not increasing: the composition theorem does not apply";
    if (!a.plot_file.empty()) {
        std::vector<double> rv;
        for (double v : c.curve_v) rv.push_back(c.rho * v);
        json p1 = {{"title", "Composed loading curve"}, {"xlabel", "v"}, {"ylabel", "eta(v)"}, {"xscale", "linear"},
                   {"series", {series_json("eta = phi o psi_est", c.curve_v, c.curve_eta),
                               series_json("rho v", c.curve_v, rv, "--")}}};
        plot({{"title", "piezoloop analyze pi"}, {"panels", {p1}}}, a.plot_file);
        out["plot"] = a.plot_file;
    }
    std::cout << out.dump(1) << "\n";
}

}  // namespace

void add_analyze(CLI::App& app) {
    CLI::App* analyze = app.add_subcommand(
        "analyze", "Loop, repetitive-control, PI-composition and mu analysis (margins, H-infinity norms, RC conditions, mu)");
    analyze->require_subcommand(1);

    auto la = std::make_shared<LoopArgs>();
    CLI::App* loop = analyze->add_subcommand(
        "loop", "Plant and controller: S, T, KS, GS norms, poles, margins, bandwidth, weighted and robust checks");
    loop->add_option("--plant", la->plant, "plant model file (JSON)")->required();
    loop->add_option("--controller", la->controller, "controller model file (JSON)")->required();
    loop->add_option("--we", la->we, "performance weight on S (JSON)");
    loop->add_option("--wy", la->wy, "performance weight on T (JSON)");
    loop->add_option("--hm", la->hm, "multiplicative uncertainty weight (JSON): robust stability");
    add_discretise(loop, la->disc);
    loop->add_option("--phase-lag-hz", la->phase_lag_hz, "comma-separated frequencies for T's phase lag");
    loop->add_option("--family-rel", la->family_rel, "relative perturbation of the plant denominator (with --hm)")
        ->check(CLI::Range(1e-6, 0.49))
        ->capture_default_str();
    loop->add_flag("--no-family", la->no_family, "skip the coefficient family (with --hm)");
    loop->add_option("--plot", la->plot_file, "write Bode / sensitivity plots to this PNG");
    loop->callback([la] { guarded([&] { run_loop(*la); }); });

    auto ra = std::make_shared<RcArgs>();
    CLI::App* rc = analyze->add_subcommand("rc", "Plug-in repetitive control: conditions (1)-(3), (15), (21) of Shan2012");
    rc->add_option("--closed-loop", ra->closed_loop, "closed loop T without RC (JSON)");
    rc->add_option("--loop-plant", ra->plant, "plant (JSON), with --controller");
    rc->add_option("--controller", ra->controller, "feedback controller Gc (JSON), with --loop-plant");
    rc->add_option("--q", ra->q, "Q filter (JSON, discrete or discretised with --rate-hz)")->required();
    rc->add_option("--krc", ra->k_rc, "RC gain k_rc")->required()->check(CLI::PositiveNumber);
    rc->add_option("--m1", ra->m1, "lead compensating Q (samples)")->required()->check(CLI::NonNegativeNumber);
    rc->add_option("--m2", ra->m2, "lead compensating the closed loop (samples)")->required()->check(CLI::NonNegativeNumber);
    rc->add_option("--period-samples", ra->period, "N: reference period in samples")->required()->check(CLI::Range(2, 1000000));
    add_discretise(rc, ra->disc);
    rc->add_option("--pi-g0", ra->pi_g0, "PI hysteresis input gain g0 (eq. 15, 21)");
    rc->add_option("--pi-density", ra->pi_density, "comma-separated PI densities d(gamma_j)");
    rc->add_option("--pi-spacing", ra->pi_spacing, "threshold spacing rho of the density (reports rho sum|d_j| too)")
        ->check(CLI::NonNegativeNumber);
    rc->add_flag("--pi-shan2012", ra->pi_shan, "use Shan2012's published forward PI set");
    rc->add_option("--plot", ra->plot_file, "write the condition curves to this PNG");
    rc->callback([ra] { guarded([&] { run_rc(*ra); }); });

    auto pa = std::make_shared<AnalyzePiArgs>();
    CLI::App* pi = analyze->add_subcommand("pi", "PI model composed with an estimated inverse: rho and the bound on Xi");
    pi->add_option("--model", pa->model, "true PI model (JSON: thresholds, weights[, p0])")->required();
    pi->add_option("--estimate", pa->estimate, "estimated forward PI model, inverted analytically");
    pi->add_option("--inverse", pa->inverse, "estimated inverse PI model");
    pi->add_option("--max-input", pa->max_input, "input amplitude limit")->check(CLI::PositiveNumber);
    pi->add_option("--plot", pa->plot_file, "write the composed loading curve to this PNG");
    pi->callback([pa] { guarded([&] { run_pi(*pa); }); });
}

namespace {
const bool registered_analyze = register_command(30, add_analyze);
}  // namespace

}  // namespace piezoloop::cli
