// `piezoloop measure frf --scenario S.json [--case C] ...`: the stage's
// frequency response from command u (V) to measured displacement y (µm) by a
// periodic multisine, or a swept sine or PRBS with the H1 estimate
// (docs/measurement.md), on the simulator. The recording
// is made by the core's excitation in the loop kernel every simulated run
// uses (host/measure/frf_sim), the estimate by host/measure/frf_estimate,
// which a board's recording will share. Every request is checked before
// anything runs (exit 2, the option and its allowed range named).
#include <unistd.h>

#include <chrono>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <iostream>
#include <memory>
#include <stdexcept>
#include <string>

#include <nlohmann/json.hpp>

#include "cli/progress_bar.hpp"
#include "commands.hpp"
#include "format/number.hpp"
#include "lti/freqresp.hpp"
#include "measure/frf_sim.hpp"
#include "sim/plotting.hpp"
#include "sim/scenario.hpp"

namespace piezoloop::cli {
namespace {

using nlohmann::json;

struct FrfArgs {
    std::string scenario, case_name, mode = "open", signal = "multisine", out, plot;
    double from_Hz = 0.0, to_Hz = 0.0, amplitude_V = 0.0, bias_V = 0.0;
    int periods = 10, transient_periods = 1;
};

json frf_json(const FrfArgs& a, const sim::Scenario& s, const measure::FrfRun& r) {
    const measure::FrfEstimate& e = r.estimate;
    json out;
    out["frequency_Hz"] = e.frequency_Hz;
    json resp = json::array(), std_db = json::array(), snr = json::array();
    for (std::size_t i = 0; i < e.response.size(); ++i) {
        resp.push_back({e.response[i].real(), e.response[i].imag()});
        std_db.push_back(std::isfinite(e.std_db[i]) ? json(e.std_db[i]) : json());
        snr.push_back(std::isfinite(e.snr_db[i]) ? json(e.snr_db[i]) : json());
    }
    out["response"] = resp;
    out["std_db"] = std_db;
    out["snr_db"] = snr;
    if (!r.coherence.empty()) out["coherence"] = r.coherence;
    out["input"] = "u: command to the amplifier after the limiter (V)";
    out["output"] = "y: measured displacement, the sensor's reading / its gain (um)";
    out["units"] = {{"frequency", "Hz"}, {"response", "um/V"}, {"std_db", "dB (one standard deviation of |G|)"}};
    out["source"] = {{"kind", "simulator"}, {"scenario", s.name}, {"case", a.case_name}};
    out["mode"] = a.mode;
    const measure::MultisineLayout& l = r.plan.layout;
    out["excitation"] = {{"signal", a.signal},
                         {"point", "command"},        {"amplitude_V", a.amplitude_V},
                         {"bias_V", a.mode == "open" ? a.bias_V : 0.0},
                         {"rate_Hz", l.rate_Hz},      {"period_samples", r.plan.period_samples},
                         {"periods", a.periods},      {"transient_periods", a.transient_periods}};
    if (a.signal == "multisine") {
        out["excitation"]["phases"] = "schroeder";
        out["excitation"]["first_bin"] = l.first_bin;
        out["excitation"]["last_bin"] = l.last_bin;
    } else {
        out["excitation"]["segment_samples"] = r.plan.segment_samples;
        out["excitation"]["segments"] = r.segments;
        if (a.signal == "sweep") out["excitation"]["law"] = "logarithmic, from_Hz to to_Hz over period_samples";
        else out["excitation"]["prbs"] = {{"order", r.plan.prbs_order}, {"hold_samples", r.plan.prbs_hold}};
    }
    if (a.mode == "closed") out["excitation"]["setpoint_um"] = a.bias_V * s.command_um_per_V();
    out["method"] = a.signal == "multisine"
                        ? "per-period DFT at the excited bins, averaged over the periods; variance from the "
                          "period-to-period spread (Pintelon & Schoukens 2012, ch. 2)"
                        : "H1 = S_yu / S_uu, Welch: Hann-windowed half-overlapping segments; std_db from the "
                          "coherence (Bendat & Piersol 2010, table 9.6)";
    out["clipped_samples"] = r.clipped_samples;
    out["clipped_samples_transient"] = r.clipped_transient;
    out["limiter_trip"] = r.trip;
    out["warnings"] = r.warnings;
    out["log_hash"] = format::hex64(r.log_hash);
    out["wall_s"] = r.wall_s;
    return out;
}

void plot_frf(const std::string& png, const sim::Scenario& s, const measure::FrfRun& r) {
    const measure::FrfEstimate& e = r.estimate;
    json mag = json::array(), ph = json::array(), sd = json::array(), coh = json::array();
    for (std::size_t i = 0; i < e.response.size(); ++i) {
        mag.push_back(design::magnitude_db(e.response[i]));
        ph.push_back(design::phase_deg(e.response[i]));
        sd.push_back(std::isfinite(e.std_db[i]) ? e.std_db[i] : 0.0);
        if (!r.coherence.empty()) coh.push_back(r.coherence[i]);
    }
    auto panel = [&](const std::string& title, const std::string& ylabel, const json& y, const std::string& yscale) {
        return json{{"title", title},
                    {"xlabel", "frequency (Hz)"},
                    {"ylabel", ylabel},
                    {"xscale", "log"},
                    {"yscale", yscale},
                    {"series", json::array({{{"label", "measured"}, {"x", e.frequency_Hz}, {"y", y}, {"style", "-"}}})}};
    };
    json spec;
    spec["title"] = s.name + ": measured frequency response u (V) -> y (um), " + r.plan.signal;
    spec["panels"] = json::array({panel("magnitude", "dB (um/V)", mag, "linear"), panel("phase", "deg", ph, "linear"),
                                  r.coherence.empty() ? panel("standard deviation of |G|", "dB", sd, "log")
                                                      : panel("coherence", "", coh, "linear")});
    sim::plot_spec("plot.py", spec, {std::filesystem::absolute(png).string()});
}

int run_frf(const FrfArgs& a) {
    const sim::Scenario s = sim::load_scenario(a.scenario);
    const sim::CaseSpec* c = a.case_name.empty() ? nullptr : &s.find_case(a.case_name);
    measure::FrfRequest r;
    r.signal = a.signal;
    r.from_Hz = a.from_Hz;
    r.to_Hz = a.to_Hz;
    r.amplitude_V = a.amplitude_V;
    r.bias_V = a.bias_V;
    r.closed = a.mode == "closed";
    r.periods = a.periods;
    r.transient_periods = a.transient_periods;
    if (r.closed && !c) throw std::invalid_argument("--case: closed loop needs the case whose controller closes it");
    (void)measure::plan_frf(s, r);  // refuses before anything runs (and before --out is touched)
    const auto t0 = std::chrono::steady_clock::now();
    bool shown = false;
    const measure::FrfRun run = measure::run_frf_sim(s, c, r, [&](double f) { progress_bar(f, t0, shown); });
    const double total_s = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
    const json out = frf_json(a, s, run);
    std::ofstream f(a.out);
    if (!f) throw std::runtime_error("--out: cannot write " + a.out);
    f << out.dump(1) << "\n";
    if (!f) throw std::runtime_error("--out: cannot write " + a.out);
    if (!a.plot.empty()) plot_frf(a.plot, s, run);
    const double simulated_s = static_cast<double>(run.plan.ticks) / s.rate_Hz;
    std::cout << json{{"out", a.out},
                      {"lines", run.estimate.frequency_Hz.size()},
                      {"from_Hz", run.estimate.frequency_Hz.front()},
                      {"to_Hz", run.estimate.frequency_Hz.back()},
                      {"line_spacing_Hz", run.estimate.frequency_Hz.size() > 1
                                              ? run.estimate.frequency_Hz[1] - run.estimate.frequency_Hz[0]
                                              : 0.0},
                      {"simulated_s", simulated_s},
                      {"wall_s", total_s},
                      {"clipped_samples", run.clipped_samples},
                      {"warnings", run.warnings}}
                     .dump(1)
              << "\n";
    std::cerr << "measure frf: " << run.estimate.frequency_Hz.size() << " lines, " << format::significant(simulated_s, 4)
              << " s simulated in " << format::significant(total_s, 3) << " s wall\n";
    return 0;
}

void add_measure(CLI::App& app) {
    CLI::App* measure = app.add_subcommand("measure", "Measure a stage on the simulator: frequency response, step response, hysteresis loops");
    measure->require_subcommand(1);
    auto a = std::make_shared<FrfArgs>();
    CLI::App* cmd = measure->add_subcommand(
        "frf", "Frequency response u (V) -> y (um): periodic multisine with Schroeder phases, or swept sine / PRBS "
        "with H1 and coherence (docs/measurement.md)");
    cmd->add_option("--scenario", a->scenario, "scenario file (configs/*.json): the simulated stage")
        ->required()
        ->check(CLI::ExistingFile);
    cmd->add_option("--case", a->case_name, "case: its controller (closed loop) and any hysteresis override");
    cmd->add_option("--from-hz", a->from_Hz, "lowest frequency; also the line spacing (period = rate / F1)")
        ->required();
    cmd->add_option("--to-hz", a->to_Hz, "highest frequency, below rate / 2")->required();
    cmd->add_option("--amplitude-v", a->amplitude_V, "peak of the excitation at the command (V)")->required();
    cmd->add_option("--bias-v", a->bias_V, "open loop: the command the excitation is centred on (V); closed loop: "
                                           "the setpoint, as the displacement this command gives at the mean slope");
    cmd->add_option("--mode", a->mode, "open: no controller; closed: the case's controller runs")
        ->check(CLI::IsMember({"open", "closed"}));
    cmd->add_option("--signal", a->signal, "excitation: multisine (periodic estimate), sweep or prbs (H1, Welch, coherence)")->check(CLI::IsMember({"multisine", "sweep", "prbs"}));
    cmd->add_option("--periods", a->periods, "measured periods, averaged (>= 2 for the variance)");
    cmd->add_option("--transient-periods", a->transient_periods, "periods run first and discarded");
    cmd->add_option("--out", a->out, "the response as JSON")->required();
    cmd->add_option("--plot", a->plot, "magnitude, phase and standard deviation as a PNG (tools/plot.py)");
    cmd->callback([a] { guarded([&] { return run_frf(*a); }); });
}

const bool registered = register_command(45, add_measure);

}  // namespace
}  // namespace piezoloop::cli
