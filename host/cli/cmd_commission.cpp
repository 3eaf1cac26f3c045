// `piezoloop [--device ADDR] commission [--scenario S.json] --range-um R
// [--target-bandwidth-hz F] [--no-save] --out DIR`: a stage commissioned
// from measurements alone, on a board or on the simulator
// (host/commission/commission.hpp, docs/commissioning.md): safety steps,
// frequency response, model fit, a robust and a classic candidate checked on
// the measured response, the better predicted tracker chosen, loaded and
// verified on the stage beside its prediction; on a board the result is
// saved (`save`) unless --no-save. Writes DIR/report.md, DIR/controller.json
// (the chosen controller, a model file), DIR/frf.json (the measurement, for
// `identify tf` and `analyze measured-loop`) and DIR/scenario.json (the
// stage as identified with the commissioned case, for `piezoloop sim`), and
// prints a JSON summary. Exit 2 for a bad request (nothing moved), 1 when a
// safety step stops it or no candidate passes (nothing loaded or saved; the
// report says why). The summary's wall_s is the whole run's wall time (the
// issue's targets: <= 120 s on an emulated board, <= 20 s on the simulator).
#include <chrono>
#include <filesystem>
#include <fstream>
#include <iostream>
#include <memory>
#include <string>

#include <nlohmann/json.hpp>

#include "commands.hpp"
#include "commission/commission.hpp"
#include "commission/commission_figures.hpp"
#include "commission/sim_stage.hpp"
#include "device_common.hpp"
#include "exit_codes.hpp"
#include "format/number.hpp"
#include "link/board_stage.hpp"
#include "lti/model_json.hpp"
#include "measure/frf_report.hpp"
#include "sim/plotting.hpp"
#include "sim/scenario.hpp"

namespace piezoloop::cli {
namespace {

using nlohmann::json;

struct CommissionArgs {
    std::string scenario, out;
    bool no_save = false;
    commission::CommissionRequest request;
};

std::string fmt(double v, int digits = 4) { return format::significant(v, digits); }

json tracking_json(const commission::TrackingRun& t) {
    return {{"e_max_pct", t.e_max_pct}, {"e_rms_pct", t.e_rms_pct}, {"e_max_um", t.e_max_um},
            {"hysteresis_pct", t.hysteresis_pct}, {"trip", t.trip}};
}

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
            {"predicted_10Hz_half_range", k.predicted ? tracking_json(*k.predicted) : json()},
            {"controller", k.passes ? design::to_json(k.controller) : json()}};
}

std::string report_md(const CommissionArgs& a, const std::string& stage, double rate_Hz,
                      const commission::Commissioning& c, const std::string& kept) {
    std::string t = "# piezoloop commission\n\n";
    t += "Stage: " + stage + " (the tool reads only its measurements). Range " + fmt(a.request.range_um) +
         " µm about " + fmt(c.centre_um) + " µm (the stage at mid-span), loop rate " + fmt(rate_Hz) + " Hz.\n\n## Steps\n\n";
    for (const std::string& l : c.log) t += "- " + l + "\n";
    t += "\n## Safety steps (open loop, from mid-span)\n\n| step (V) | Δy (µm) | noise (µm) | gain (µm/V) |\n|---:|---:|---:|---:|\n";
    for (const auto& st : c.safety)
        t += "| " + fmt(st.step_V) + " | " + fmt(st.dy_um) + " | " + fmt(st.noise_um, 2) + " | " + fmt(st.gain_um_per_V) + " |\n";
    t += "\n## Model fits (continuous, one tick of delay taken out)\n\n| order | RMS error (lines with SNR >= 20 dB) | DC gain (µm/V) | chosen |\n|---|---:|---:|---|\n";
    for (std::size_t i = 0; i < c.fits.size(); ++i)
        t += "| " + std::to_string(c.fits[i].poles) + "/" + std::to_string(c.fits[i].zeros) + " | " +
             fmt(100.0 * c.fits[i].rms_rel, 3) + " % | " + fmt(c.fits[i].dc_gain_um_per_V) + " | " +
             (static_cast<int>(i) == c.chosen_fit ? "yes" : "") + " |\n";
    t += "\n## Candidates (checked on the measured response; tracking predicted on the identified stage, 10 Hz "
         "triangle over half the range)\n\n"
         "| candidate | how | order | PM (measured) | GM (measured) | max\\|S\\| | predicted e_max | verdict |\n"
         "|---|---|---:|---:|---:|---:|---:|---|\n";
    for (std::size_t i = 0; i < c.candidates.size(); ++i) {
        const auto& k = c.candidates[i];
        const auto& m = k.measured;
        t += "| " + k.name + " | " + k.method + " | " + std::to_string(k.order) + " | " +
             (m.phase_margin ? fmt(m.phase_margin->value, 3) + "° at " + fmt(m.phase_margin->f_Hz, 3) + " Hz" : "–") +
             " | " + (m.gain_margin ? fmt(m.gain_margin->value, 3) + " dB" : "–") + " | " + fmt(m.max_sensitivity, 3) +
             " | " + (k.predicted ? fmt(k.predicted->e_max_pct, 3) + " %" : "–") + " | " +
             (static_cast<int>(i) == c.chosen ? "**chosen**" : k.passes ? "passes" : "refused: " + k.refusal) + " |\n";
    }
    if (c.chosen < 0) return t + "\nNo candidate passed the checks on the measurement: nothing was loaded or kept.\n";
    t += "\n## Verification on the stage (feedback alone, triangles about " + fmt(c.centre_um) +
         " µm)\n\nClosed-loop bandwidth from the measured lines (|L/(1+L)| at -3 dB): " + fmt(c.bandwidth_Hz, 3) +
         " Hz.\n\n| triangle | range (µm) | e_max measured | predicted | e_rms measured | predicted | hysteresis measured | trip |\n"
         "|---|---:|---:|---:|---:|---:|---:|---|\n";
    for (const auto& v : c.verification)
        t += "| " + fmt(v.request.frequency_Hz, 3) + " Hz | " + fmt(v.request.range_um) + " | " +
             fmt(v.measured.e_max_pct, 3) + " % | " + fmt(v.predicted.e_max_pct, 3) + " % | " +
             fmt(v.measured.e_rms_pct, 3) + " % | " + fmt(v.predicted.e_rms_pct, 3) + " % | " +
             (v.measured.hysteresis_pct >= 0.0 ? fmt(v.measured.hysteresis_pct, 3) + " %" : "–") + " | " +
             v.measured.trip + " |\n";
    t += "\nThe identified stage is a linear model: the stage's hysteresis is in the measured figures, not in the "
         "predicted ones.\n\nThe chosen controller is in controller.json (e in µm -> u in V; `error_per_um` 1); "
         "scenario.json is the identified stage with it as case `commissioned` (`piezoloop sim --scenario "
         "scenario.json --case commissioned`).\n\n" + kept + "\n";
    return t;
}

int run_commission(const CommissionArgs& a) {
    const auto t0 = std::chrono::steady_clock::now();
    const bool on_board = a.scenario.empty();
    if (on_board && device_address().empty())
        throw std::invalid_argument("--scenario: give a scenario (simulator) or --device ADDR before `commission` (board)");
    if (!on_board && !device_address().empty())
        throw std::invalid_argument("--scenario: commissions the simulator; drop it to commission the board given by --device");
    if (!on_board && a.no_save) throw std::invalid_argument("--no-save: only on a board (--device)");
    auto say = [](const std::string& line) { std::cerr << "commission: " << line << "\n"; };

    std::unique_ptr<hostlink::Client> client;
    std::unique_ptr<commission::StageAccess> stage;
    std::optional<StopSignals> stop_signals;
    json source;
    if (on_board) {
        client = std::make_unique<hostlink::Client>(open_device());
        // A board that has never been configured has no command span: the
        // commissioning works within its hard limits then.
        const link::LimitsParams limits = client->get<link::LimitsParams>();
        if (!(limits.limits.u_max_V > limits.limits.u_min_V)) {
            const link::HelloReply& h = client->info();
            link::LimitsParams l;
            l.limits = {h.hard_u_min_V, h.hard_u_max_V, h.hard_slew_max_V_per_s, 0.0f};
            client->set(l);
            say("the board has no limits set: using its hard limits, " + fmt(h.hard_u_min_V) + " .. " +
                fmt(h.hard_u_max_V) + " V, " + fmt(h.hard_slew_max_V_per_s) + " V/s");
        }
        stop_signals.emplace();
        hostlink::MeasureOptions o;
        o.stop_requested = [] { return StopSignals::requested(); };
        stage = std::make_unique<hostlink::BoardStage>(*client, o);
        source = {{"kind", "board"}, {"device", client->address()}, {"board", client->info().board.data()}};
    } else {
        const sim::Scenario s = sim::load_scenario(a.scenario);
        source = {{"kind", "simulator"}, {"scenario", s.name}, {"case", ""}};
        stage = std::make_unique<commission::SimStage>(s);
    }
    commission::Commissioning c;
    try {
        c = commission::commission(*stage, a.request, say);
    } catch (...) {
        // Whatever stopped it, a board is left disarmed (the measurement
        // sessions put its groups back).
        if (client) try { client->disarm(); } catch (const std::exception&) {}
        throw;
    }
    const double rate_Hz = stage->loop().rate_Hz;
    std::string kept = "Nothing was kept: the simulator has no storage.";
    json saved;
    if (c.chosen >= 0 && !c.verified()) {
        kept = "Not kept: the verification failed (" + c.verification_failure + ").";
    } else if (on_board && c.chosen >= 0) {
        if (a.no_save) {
            kept = "Loaded, not saved (--no-save): the board forgets it at its next boot.";
        } else {
            client->save();
            kept = "Saved on the board (`save`): applied, disarmed, at its next boot.";
            saved = true;
        }
        say(kept);
    }

    std::filesystem::create_directories(a.out);
    const std::filesystem::path dir(a.out);
    auto write = [&](const std::string& name, const std::string& text) {
        std::ofstream f(dir / name);
        if (!(f << text)) throw std::runtime_error("--out: cannot write " + (dir / name).string());
    };
    // The figures; a report without them is still a report.
    std::string figures = "Figures: frf.png (measured and fitted response), loops.png (hysteresis loop and PI model), "
                          "candidates.png (loop and sensitivity on the measured lines)" +
                          std::string(c.verification.empty() ? "" : ", verification.png (tracking, measured and predicted)") +
                          ".";
    try {
        sim::plot_spec("plot_sim.py", commission::commission_figures(c, std::filesystem::absolute(dir)));
    } catch (const std::exception& e) {
        figures = std::string("The figures could not be drawn: ") + e.what();
        say("warning: " + figures);
    }
    write("report.md", report_md(a, stage->describe(), rate_Hz, c, kept) + "\n" + figures + "\n");
    write("frf.json", measure::frf_report(c.frf_request, c.frf, source).dump(1) + "\n");
    json out;
    out["stage"] = stage->describe();
    out["range_um"] = a.request.range_um;
    out["centre_um"] = c.centre_um;
    out["gain_um_per_V"] = c.gain_um_per_V;
    out["target_bandwidth_Hz"] = c.target_bandwidth_Hz;
    const auto& fit = c.fits[static_cast<std::size_t>(c.chosen_fit)];
    out["model"] = {{"order", std::to_string(fit.poles) + "/" + std::to_string(fit.zeros)}, {"rms_rel", fit.rms_rel}};
    json cands = json::array();
    for (const auto& k : c.candidates) cands.push_back(candidate_json(k));
    out["candidates"] = cands;
    out["chosen"] = c.chosen >= 0 ? json(c.candidates[static_cast<std::size_t>(c.chosen)].name) : json();
    out["report"] = (dir / "report.md").string();
    if (c.chosen >= 0) {
        const auto& k = c.candidates[static_cast<std::size_t>(c.chosen)];
        out["bandwidth_Hz"] = c.bandwidth_Hz;
        json v = json::array();
        for (const auto& r : c.verification)
            v.push_back({{"frequency_Hz", r.request.frequency_Hz},
                         {"range_um", r.request.range_um},
                         {"measured", tracking_json(r.measured)},
                         {"predicted", tracking_json(r.predicted)}});
        out["verification"] = v;
        json m = design::to_json(k.controller);
        m["description"] = "commissioned by piezoloop commission on " + stage->describe() + ": " + k.name + " (" +
                           k.method + "); e (um) -> u (V)";
        write("controller.json", m.dump(1) + "\n");
        write("scenario.json", commission::commissioned_scenario(c).dump(1) + "\n");
        out["controller_file"] = (dir / "controller.json").string();
        out["scenario_file"] = (dir / "scenario.json").string();
        out["verified"] = c.verified();
        if (!c.verified()) out["verification_failure"] = c.verification_failure;
        if (on_board) out["saved"] = c.verified() && !a.no_save;
    }
    out["wall_s"] = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
    std::cout << out.dump(1) << "\n";
    return c.verified() ? kExitOk : kExitFailure;
}

void add_commission(CLI::App& app) {
    auto a = std::make_shared<CommissionArgs>();
    CLI::App* cmd = app.add_subcommand(
        "commission", "Commission a stage from measurements alone, on the board given by --device or a simulated "
                      "stage: safety steps, frequency response, model fit, a robust and a classic candidate checked "
                      "on the measurement, the better loaded, verified and saved (docs/commissioning.md)");
    cmd->add_option("--scenario", a->scenario,
                    "simulator: the scenario whose stage is measured (open loop); without it, the board (--device)")
        ->check(CLI::ExistingFile);
    cmd->add_option("--range-um", a->request.range_um, "travel the loop must hold (um)")->required();
    cmd->add_option("--target-bandwidth-hz", a->request.target_bandwidth_Hz,
                    "crossover to design for (default: a third of the first lightly damped mode, at most rate / 20)");
    cmd->add_flag("--no-save", a->no_save, "board: load and verify, but do not save the result on the board");
    cmd->add_option("--out", a->out, "directory for report.md, controller.json, frf.json, scenario.json")->required();
    cmd->callback([a] { guarded([&] { return run_commission(*a); }); });
}

const bool registered = register_command(47, add_commission);

}  // namespace
}  // namespace piezoloop::cli
