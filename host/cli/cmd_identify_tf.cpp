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
#include "measure/tf_fit.hpp"

namespace piezoloop::cli {
namespace {

using nlohmann::json;

struct TfArgs {
    std::string frf, order, out;
    int delay_samples = 0;
    bool continuous = false;
};

[[noreturn]] void bad(const std::string& file, const std::string& field, const std::string& why) {
    throw std::invalid_argument(file + ": " + field + ": " + why);
}

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
    std::ifstream in(a.frf);
    if (!in) throw std::invalid_argument("--frf: cannot read " + a.frf);
    json j;
    try {
        j = json::parse(in);
    } catch (const json::exception& e) {
        throw std::invalid_argument(a.frf + ": not JSON: " + e.what());
    }
    if (!j.is_object()) bad(a.frf, "(top)", "must be an object (measure frf's output)");
    auto array_of = [&](const char* key) {
        if (!j.contains(key) || !j[key].is_array()) bad(a.frf, key, "missing or not an array");
        return j[key];
    };
    const json f = array_of("frequency_Hz"), r = array_of("response");
    if (f.size() != r.size()) bad(a.frf, "response", "must have one [re, im] pair per frequency");
    std::vector<double> f_Hz, var;
    std::vector<design::cplx> g;
    for (std::size_t i = 0; i < f.size(); ++i) {
        if (!f[i].is_number()) bad(a.frf, "frequency_Hz[" + std::to_string(i) + "]", "must be a number");
        if (!r[i].is_array() || r[i].size() != 2 || !r[i][0].is_number() || !r[i][1].is_number())
            bad(a.frf, "response[" + std::to_string(i) + "]", "must be [re, im]");
        f_Hz.push_back(f[i].get<double>());
        g.emplace_back(r[i][0].get<double>(), r[i][1].get<double>());
    }
    if (j.contains("std_db")) {
        const json s = array_of("std_db");
        if (s.size() != f.size()) bad(a.frf, "std_db", "must have one entry per frequency");
        const double rel_per_db = std::log(10.0) / 20.0;
        for (std::size_t i = 0; i < s.size(); ++i) {
            const double sd = s[i].is_number() ? s[i].get<double>() : std::nan("");
            var.push_back(std::pow(sd * rel_per_db * std::abs(g[i]), 2));
        }
    }
    if (!j.contains("excitation") || !j["excitation"].contains("rate_Hz") || !j["excitation"]["rate_Hz"].is_number())
        bad(a.frf, "excitation.rate_Hz", "missing: the loop rate the response was measured at");
    const double rate = j["excitation"]["rate_Hz"].get<double>();
    if (!(rate > 0.0) || !std::isfinite(rate)) bad(a.frf, "excitation.rate_Hz", "must be > 0");
    o.ts = 1.0 / rate;

    const measure::TfFit fit = measure::fit_tf(f_Hz, g, var, o);
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
const bool registered = register_command(51, add_identify_tf);

}  // namespace
}  // namespace piezoloop::cli
