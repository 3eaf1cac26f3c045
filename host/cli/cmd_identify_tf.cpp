// `piezoloop identify tf --frf frf.json --order N[/M] [--delay-samples K]
// [--continuous] [--out model.json]`: a transfer function fitted to a measured
// frequency response (`measure frf`'s JSON) by host/measure/tf_fit
// (Sanathanan–Koerner least squares weighted by 1 / variance). N poles, M
// zeros (default N - 1). JSON on stdout: the model in the model-file format
// of configs/models, its poles, resonances (frequency, damping) and the fit
// error per decade; --out writes the model file alone, ready for `design`,
// `analyze` and scenario files. An order the data cannot support is refused
// with the reason (exit 2).
#include <cmath>
#include <fstream>
#include <iostream>
#include <memory>
#include <stdexcept>
#include <string>
#include <vector>

#include <nlohmann/json.hpp>

#include "commands.hpp"
#include "lti/model_json.hpp"
#include "measure/frf_file.hpp"
#include "measure/tf_fit.hpp"

namespace piezoloop::cli {
namespace {

using nlohmann::json;

struct TfArgs {
    std::string frf, order, out;
    int delay_samples = 0;
    bool continuous = false;
};

void parse_order(const std::string& text, int& poles, int& zeros) {
    const auto slash = text.find('/');
    try {
        std::size_t used = 0;
        poles = std::stoi(text.substr(0, slash), &used);
        if (used != (slash == std::string::npos ? text.size() : slash)) throw std::invalid_argument("");
        zeros = poles - 1;
        if (slash != std::string::npos) {
            const std::string m = text.substr(slash + 1);
            zeros = std::stoi(m, &used);
            if (used != m.size()) throw std::invalid_argument("");
        }
    } catch (const std::exception&) {
        throw std::invalid_argument("--order: must be N or N/M (N poles, M zeros), e.g. 6/5");
    }
}

int run_tf(const TfArgs& a) {
    measure::TfFitOptions o;
    parse_order(a.order, o.poles, o.zeros);
    o.delay_samples = a.delay_samples;
    o.continuous = a.continuous;
    const measure::FrfData d = measure::load_frf_file(a.frf);
    // 1 / variance weights from the per-line standard deviation in dB.
    std::vector<double> var;
    const double rel_per_db = std::log(10.0) / 20.0;
    for (std::size_t i = 0; i < d.std_db.size(); ++i)
        var.push_back(std::pow(d.std_db[i] * rel_per_db * std::abs(d.response[i]), 2));
    o.ts = 1.0 / d.rate_Hz;

    const measure::TfFit fit = measure::fit_tf(d.f_Hz, d.response, var, o);
    json model = design::to_json(fit.model);
    model["name"] = "fitted to " + a.frf + " (identify tf, order " + std::to_string(o.poles) + "/" +
                    std::to_string(o.zeros) + ", delay " + std::to_string(o.delay_samples) + " samples)";
    model["source"] = "Sanathanan-Koerner least squares on the measured response (docs/measurement.md)";
    if (fit.model.ts == 0.0 && fit.delay_s > 0.0)
        model["comment"] = "a delay of " + std::to_string(fit.delay_s) + " s was taken out before the fit and is not in the model";
    json out;
    out["model"] = model;
    json poles = json::array(), res = json::array(), real_Hz = json::array();
    for (const design::cplx p : fit.poles) {
        poles.push_back({p.real(), p.imag()});
        const design::cplx s = fit.model.ts > 0.0 ? (p == 0.0 ? design::cplx(-INFINITY, 0) : std::log(p) / fit.model.ts) : p;
        if (!std::isfinite(s.real())) continue;
        if (p.imag() > 0.0) res.push_back({{"frequency_Hz", std::abs(s) / (2.0 * M_PI)}, {"damping", -s.real() / std::abs(s)}});
        else if (p.imag() == 0.0) real_Hz.push_back(-s.real() / (2.0 * M_PI));
    }
    out["poles"] = poles;
    out["resonances"] = res;
    out["real_poles_Hz"] = real_Hz;
    out["iterations"] = fit.iterations;
    out["reflected_poles"] = fit.reflected;
    out["delay_samples"] = o.delay_samples;
    if (fit.model.ts == 0.0) out["delay_s"] = fit.delay_s;
    out["weighted_rms"] = fit.weighted_rms;
    json dec = json::array();
    for (const measure::DecadeError& e : fit.decades)
        dec.push_back({{"from_Hz", e.from_Hz}, {"to_Hz", e.to_Hz}, {"lines", e.lines}, {"rms_rel", e.rms_rel},
                       {"max_rel", e.max_rel}, {"max_db", e.max_db}, {"max_deg", e.max_deg}});
    out["fit_error_per_decade"] = dec;
    if (!a.out.empty()) {
        std::ofstream m(a.out);
        if (!m) throw std::runtime_error("--out: cannot write " + a.out);
        m << model.dump(1) << "\n";
        if (!m) throw std::runtime_error("--out: cannot write " + a.out);
    }
    std::cout << out.dump(1) << "\n";
    return 0;
}

void add_identify_tf(CLI::App& app) {
    CLI::App* identify = app.get_subcommand("identify");
    auto a = std::make_shared<TfArgs>();
    CLI::App* cmd = identify->add_subcommand(
        "tf", "Transfer function fitted to a measured frequency response (measure frf's JSON): Sanathanan-Koerner "
              "least squares weighted by 1/variance, stable poles (docs/measurement.md)");
    cmd->add_option("--frf", a->frf, "frequency response JSON (piezoloop measure frf --out)")->required();
    cmd->add_option("--order", a->order, "N[/M]: N poles, M zeros (default N - 1)")->required();
    cmd->add_option("--delay-samples", a->delay_samples, "pure delay in loop ticks, taken out before the fit");
    cmd->add_flag("--continuous", a->continuous, "fit a continuous model (default: discrete at the measurement's rate)");
    cmd->add_option("--out", a->out, "write the model file (configs/models format)");
    cmd->callback([a] { guarded([&] { return run_tf(*a); }); });
}

// After `identify` (order 50), which it adds to.
const bool registered_identify_tf = register_command(51, add_identify_tf);

}  // namespace
}  // namespace piezoloop::cli
