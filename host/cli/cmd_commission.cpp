// `piezoloop commission --scenario S.json --range-um R [--target-bandwidth-hz F]
// --out DIR`: a stage commissioned from measurements alone on the simulator
// (host/commission/commission.hpp, docs/commissioning.md): safety steps,
// frequency response, model fit, a robust and a classic candidate checked on
// the measured response, the better tracker chosen. Writes DIR/report.md,
// DIR/controller.json (the chosen controller, a model file), DIR/frf.json
// (the measurement, for `identify tf` and `analyze measured-loop`) and
// prints a JSON summary. Exit 2 for a bad request, 1 when a safety step
// stops it or no candidate passes (nothing written but the report). The
// summary's wall_s is the whole run's wall time (the target: <= 20 s
// on the simulator).
#include <chrono>
#include <filesystem>
#include <fstream>
#include <iostream>
#include <memory>
#include <string>

#include <nlohmann/json.hpp>

#include "commands.hpp"
#include "commission/commission.hpp"
#include "exit_codes.hpp"
#include "format/number.hpp"
#include "lti/model_json.hpp"
#include "measure/frf_report.hpp"
#include "sim/scenario.hpp"

namespace piezoloop::cli {
namespace {

using nlohmann::json;

struct CommissionArgs {
    std::string scenario, out;
    commission::CommissionRequest request;
};

std::string fmt(double v, int digits = 4) { return format::significant(v, digits); }

std::string opt(const std::optional<double>& v) { return v ? fmt(*v, 3) : "–"; }

json candidate_json(const commission::Candidate& k) {
    const auto& m = k.measured;
    return {{"name", k.name},
            {"method", k.method},
            {"order", k.order},
            {"passes", k.passes},
            {"refusal", k.refusal},
            {"measured_phase_margin_deg", m.phase_margin ? json(m.phase_margin->value) : json()},
            {"measured_crossover_Hz", m.phase_margin ? json(m.phase_margin->f_Hz) : json()},
            {"measured_gain_margin_db", m.gain_margin ? json(m.gain_margin->value) : json()},
            {"measured_max_sensitivity", m.max_sensitivity},
            {"e_max_pct_10Hz", k.e_max_pct_10Hz ? json(*k.e_max_pct_10Hz) : json()},
            {"e_rms_pct_10Hz", k.e_rms_pct_10Hz ? json(*k.e_rms_pct_10Hz) : json()},
            {"e_max_pct_1Hz", k.e_max_pct_1Hz ? json(*k.e_max_pct_1Hz) : json()},
            {"controller", k.passes ? design::to_json(k.controller) : json()}};
}

std::string report_md(const CommissionArgs& a, const sim::Scenario& s, const commission::Commissioning& c) {
    std::string t = "# piezoloop commission: " + s.name + "\n\n";
    t += "Stage: the simulated stage of `" + a.scenario + "` (open loop; the tool reads only its measurements). Range " +
         fmt(a.request.range_um) + " µm, loop rate " + fmt(s.rate_Hz) + " Hz.\n\n## Steps\n\n";
    for (const std::string& l : c.log) t += "- " + l + "\n";
    t += "\n## Safety steps (open loop, from mid-span)\n\n| step (V) | Δy (µm) | noise (µm) | gain (µm/V) |\n|---:|---:|---:|---:|\n";
    for (const auto& st : c.safety)
        t += "| " + fmt(st.step_V) + " | " + fmt(st.dy_um) + " | " + fmt(st.noise_um, 2) + " | " + fmt(st.gain_um_per_V) + " |\n";
    t += "\n## Model fits (continuous, one tick of delay taken out)\n\n| order | RMS error (lines with SNR >= 20 dB) | DC gain (µm/V) | chosen |\n|---|---:|---:|---|\n";
    for (std::size_t i = 0; i < c.fits.size(); ++i)
        t += "| " + std::to_string(c.fits[i].poles) + "/" + std::to_string(c.fits[i].zeros) + " | " +
             fmt(100.0 * c.fits[i].rms_rel, 3) + " % | " + fmt(c.fits[i].dc_gain_um_per_V) + " | " +
             (static_cast<int>(i) == c.chosen_fit ? "yes" : "") + " |\n";
    t += "\n## Candidates (checked on the measured response; tracking simulated, triangle over half the range)\n\n"
         "| candidate | how | order | PM (measured) | GM (measured) | max\\|S\\| | e_max 10 Hz | e_rms 10 Hz | e_max 1 Hz | verdict |\n"
         "|---|---|---:|---:|---:|---:|---:|---:|---:|---|\n";
    for (std::size_t i = 0; i < c.candidates.size(); ++i) {
        const auto& k = c.candidates[i];
        const auto& m = k.measured;
        t += "| " + k.name + " | " + k.method + " | " + std::to_string(k.order) + " | " +
             (m.phase_margin ? fmt(m.phase_margin->value, 3) + "° at " + fmt(m.phase_margin->f_Hz, 3) + " Hz" : "–") +
             " | " + (m.gain_margin ? fmt(m.gain_margin->value, 3) + " dB" : "–") + " | " + fmt(m.max_sensitivity, 3) +
             " | " + opt(k.e_max_pct_10Hz) + " % | " + opt(k.e_rms_pct_10Hz) + " % | " + opt(k.e_max_pct_1Hz) + " % | " +
             (static_cast<int>(i) == c.chosen ? "**chosen**" : k.passes ? "passes" : "refused: " + k.refusal) + " |\n";
    }
    t += c.chosen >= 0 ? "\nThe chosen controller is in controller.json (e in µm -> u in V; `error_per_um` 1).\n"
                       : "\nNo candidate passed the checks on the measurement: nothing is chosen.\n";
    return t;
}

int run_commission(const CommissionArgs& a) {
    const auto t0 = std::chrono::steady_clock::now();
    const sim::Scenario s = sim::load_scenario(a.scenario);
    const commission::Commissioning c =
        commission::commission_sim(s, a.request, [](const std::string& line) { std::cerr << "commission: " << line << "\n"; });
    std::filesystem::create_directories(a.out);
    const std::filesystem::path dir(a.out);
    auto write = [&](const std::string& name, const std::string& text) {
        std::ofstream f(dir / name);
        if (!(f << text)) throw std::runtime_error("--out: cannot write " + (dir / name).string());
    };
    write("report.md", report_md(a, s, c));
    write("frf.json", measure::frf_report(c.frf_request, c.frf, {{"kind", "simulator"}, {"scenario", s.name}, {"case", ""}}).dump(1) + "\n");
    json out;
    out["scenario"] = s.name;
    out["range_um"] = a.request.range_um;
    out["gain_um_per_V"] = c.gain_um_per_V;
    out["target_bandwidth_Hz"] = c.target_bandwidth_Hz;
    const auto& fit = c.fits[static_cast<std::size_t>(c.chosen_fit)];
    out["model"] = {{"order", std::to_string(fit.poles) + "/" + std::to_string(fit.zeros)},
                    {"rms_rel", fit.rms_rel}};
    json cands = json::array();
    for (const auto& k : c.candidates) cands.push_back(candidate_json(k));
    out["candidates"] = cands;
    out["chosen"] = c.chosen >= 0 ? json(c.candidates[static_cast<std::size_t>(c.chosen)].name) : json();
    out["report"] = (dir / "report.md").string();
    out["wall_s"] = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
    if (c.chosen >= 0) {
        const auto& k = c.candidates[static_cast<std::size_t>(c.chosen)];
        json m = design::to_json(k.controller);
        m["description"] = "commissioned by piezoloop commission on " + s.name + ": " + k.name + " (" + k.method +
                           "); e (um) -> u (V)";
        write("controller.json", m.dump(1) + "\n");
        out["controller_file"] = (dir / "controller.json").string();
    }
    std::cout << out.dump(1) << "\n";
    return c.chosen >= 0 ? kExitOk : kExitFailure;
}

void add_commission(CLI::App& app) {
    auto a = std::make_shared<CommissionArgs>();
    CLI::App* cmd = app.add_subcommand(
        "commission", "Commission a stage from measurements alone: safety steps, frequency response, model fit, a robust "
                      "and a classic candidate checked on the measurement, the better tracker chosen (docs/commissioning.md)");
    cmd->add_option("--scenario", a->scenario, "scenario file: its stage is measured (open loop) in the simulator")
        ->required()
        ->check(CLI::ExistingFile);
    cmd->add_option("--range-um", a->request.range_um, "travel the loop must hold (um)")->required();
    cmd->add_option("--target-bandwidth-hz", a->request.target_bandwidth_Hz,
                    "crossover to design for (default: a third of the first lightly damped mode, at most rate / 20)");
    cmd->add_option("--out", a->out, "directory for report.md, controller.json, frf.json")->required();
    cmd->callback([a] { guarded([&] { return run_commission(*a); }); });
}

const bool registered = register_command(47, add_commission);

}  // namespace
}  // namespace piezoloop::cli
