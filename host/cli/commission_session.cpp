#include "commission_session.hpp"

#include <chrono>
#include <filesystem>
#include <fstream>
#include <memory>
#include <numbers>
#include <optional>
#include <stdexcept>
#include <string>

#include "commission/commission_figures.hpp"
#include "commission/sim_stage.hpp"
#include "device_common.hpp"
#include "format/number.hpp"
#include "link/board_stage.hpp"
#include "lti/model_json.hpp"
#include "measure/frf_report.hpp"
#include "sim/plotting.hpp"
#include "sim/scenario.hpp"

namespace piezoloop::cli {
namespace {

using nlohmann::json;

std::string fmt(double v, int digits = 4) { return format::significant(v, digits); }

// The stage as commissioning sees it, with the measurement plans' refusals
// put in its own words: the plans name `measure`'s options (--duration-s,
// --from-hz, ...), which commission chooses itself from the loop rate and
// the limits; what the user can change is the stage (`source_option`: the
// scenario's loop, or the board's).
class CommissionedStage : public commission::StageAccess {
public:
    CommissionedStage(std::unique_ptr<commission::StageAccess> s, std::string source_option)
        : s_(std::move(s)), source_(std::move(source_option)) {}
    std::string describe() const override { return s_->describe(); }
    commission::LoopFacts loop() override { return s_->loop(); }
    measure::MeasureBounds bounds() override { return s_->bounds(); }
    measure::StepRun step(const measure::StepRequest& r) override {
        return planned("step response", [&] { return s_->step(r); });
    }
    measure::FrfRun frf(const measure::FrfRequest& r) override {
        return planned("frequency response", [&] { return s_->frf(r); });
    }
    measure::LoopsRun loops(const measure::LoopsRequest& r) override {
        return planned("hysteresis loops", [&] { return s_->loops(r); });
    }
    commission::TrackingRun track(const commission::Controller& k, const commission::TrackRequest& t) override {
        return s_->track(k, t);
    }

private:
    template <class F>
    auto planned(const char* what, F&& f) -> decltype(f()) {
        try {
            return f();
        } catch (const std::invalid_argument& e) {
            const measure::MeasureBounds b = s_->bounds();
            throw std::invalid_argument(source_ + ": commissioning cannot measure this stage's " + what + " with its " +
                                        fmt(b.rate_Hz) + " Hz loop and " + fmt(b.limits.u_min_V) + " .. " + fmt(b.limits.u_max_V) +
                                        " V command limits (its plan refused: " + e.what() +
                                        "). Commission chooses that measurement from the loop rate and the "
                                        "limits: change " +
                                        (source_ == "--scenario" ? "the scenario's loop.rate_Hz or loop.limits"
                                                                 : "the board's loop rate or limits"));
        }
    }

    std::unique_ptr<commission::StageAccess> s_;
    std::string source_;
};

json tracking_json(const commission::TrackingRun& t) {
    const commission::TrackingDiagnosis& d = t.diagnosis;
    return {{"e_max_pct", t.e_max_pct}, {"e_rms_pct", t.e_rms_pct}, {"e_max_um", t.e_max_um},
            {"hysteresis_pct", t.hysteresis_pct}, {"trip", t.trip},
            {"diagnosis",
             {{"limited_fraction", d.limited_fraction}, {"rail_fraction", d.rail_fraction},
              {"oscillation_rms_um", d.oscillation_rms_um}, {"oscillation_Hz", d.oscillation_Hz},
              {"growing", d.growing}}}};
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

std::string margins_text(const design::MeasuredLoop& m) {
    return (m.phase_margin ? fmt(m.phase_margin->value, 3) + "° at " + fmt(m.phase_margin->f_Hz, 3) + " Hz" : "–") +
           " / " + (m.gain_margin ? fmt(m.gain_margin->value, 3) + " dB" : "–") + " / " + fmt(m.max_sensitivity, 3);
}

std::string through_inverse_md(const commission::ThroughInverse& ti, const std::vector<commission::Candidate>& candidates) {
    std::string t = "\n## Through the inverse in series (closed loop with `" + ti.probe +
                    "`)\n\nIts check triangle on the stage: e_max " + fmt(ti.probe_measured.e_max_pct, 3) +
                    " % (predicted " + fmt(ti.probe_predicted.e_max_pct, 3) + " %). " + ti.note + ".\n";
    if (ti.before.empty()) return t;
    t += "\n| candidate | PM / GM / max\\|S\\| as designed on the unit-gain model | after dividing by the measured gain |\n"
         "|---|---|---|\n";
    for (const auto& [name, before] : ti.before)
        for (const auto& k : candidates)
            if (k.name == name)
                t += "| " + name + " | " + margins_text(before) + " | " + margins_text(k.measured) +
                     (k.passes ? "" : " (refused: " + k.refusal + ")") + " |\n";
    return t;
}

json through_inverse_json(const commission::ThroughInverse& ti, const std::vector<commission::Candidate>& candidates) {
    json before = json::array();
    for (const auto& [name, m] : ti.before) {
        json after;
        for (const auto& k : candidates)
            if (k.name == name)
                after = {{"phase_margin_deg", k.measured.phase_margin ? json(k.measured.phase_margin->value) : json()},
                         {"gain_margin_db", k.measured.gain_margin ? json(k.measured.gain_margin->value) : json()},
                         {"max_sensitivity", k.measured.max_sensitivity}};
        before.push_back({{"candidate", name},
                          {"designed_on_unit_gain",
                           {{"phase_margin_deg", m.phase_margin ? json(m.phase_margin->value) : json()},
                            {"gain_margin_db", m.gain_margin ? json(m.gain_margin->value) : json()},
                            {"max_sensitivity", m.max_sensitivity}}},
                          {"on_measured_gain", after}});
    }
    return {{"probe", ti.probe},
            {"probe_measured", tracking_json(ti.probe_measured)},
            {"probe_predicted", tracking_json(ti.probe_predicted)},
            {"probe_max_sensitivity", ti.probe_max_sensitivity},
            {"probe_max_sensitivity_Hz", ti.probe_max_sensitivity_Hz},
            {"lines", ti.f_Hz.size()},
            {"gain_magnitude", ti.gain_magnitude},
            {"gain_phase_deg", ti.gain_phase_deg},
            {"note", ti.note},
            {"margins", before}};
}

std::string report_md(const CommissionSession& a, const std::string& stage, double rate_Hz,
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
    if (c.uncertainty)
        t += "\n## Uncertainty weight\n\nThe chosen fit's error on the lines with SNR >= 20 dB as W3 = r0 (1 + s/wz) / "
             "(1 + s/wp): r0 " + fmt(100.0 * c.uncertainty->r0, 3) + " %, rising from " +
             fmt(c.uncertainty->wz_rad_s / (2.0 * std::numbers::pi), 3) + " Hz to 200 % (" +
             std::to_string(c.uncertainty->uncovered_lines) + " lines above it). The candidate `robust, uncertainty` "
             "is designed with it on T.\n";
    t += "\n## Hysteresis (open loop, " + fmt(c.loops_request.frequency_Hz) + " Hz, " +
         fmt(c.loops_request.base_V) + " V to " + fmt(c.loops_request.base_V + c.loops_request.amplitudes_V.at(0)) +
         " V)\n\n" + c.hysteresis_note + "\n";
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
    if (c.through_inverse) t += through_inverse_md(*c.through_inverse, c.candidates);
    if (c.chosen < 0) return t + "\nNo candidate passed the checks on the measurement: nothing was loaded or kept.\n";
    t += "\n## Verification on the stage (feedback alone, triangles about " + fmt(c.centre_um) +
         " µm)\n\nClosed-loop bandwidth (|T| at -3 dB) measured on the stage: " +
         (c.measured_bandwidth_Hz > 0.0 || !c.closed_frf
              ? fmt(c.measured_bandwidth_Hz, 3) + " Hz"
              : "above the band measured (|T| above -3 dB up to " +
                    fmt(c.closed_frf->estimate.frequency_Hz.back(), 3) + " Hz)") +
         "; from the open-loop lines and the controller, |L/(1+L)|: " +
         fmt(c.bandwidth_Hz, 3) + " Hz.\n\n| triangle | range (µm) | e_max measured | predicted | e_rms measured | predicted | hysteresis measured | trip |\n"
         "|---|---:|---:|---:|---:|---:|---:|---|\n";
    for (const auto& v : c.verification)
        t += "| " + fmt(v.request.frequency_Hz, 3) + " Hz | " + fmt(v.request.range_um) + " | " +
             fmt(v.measured.e_max_pct, 3) + " % | " + fmt(v.predicted.e_max_pct, 3) + " % | " +
             fmt(v.measured.e_rms_pct, 3) + " % | " + fmt(v.predicted.e_rms_pct, 3) + " % | " +
             (v.measured.hysteresis_pct >= 0.0 ? fmt(v.measured.hysteresis_pct, 3) + " %" : "–") + " | " +
             v.measured.trip + " |\n";
    if (!c.fastest_text.empty()) t += "\nFastest triangle: " + c.fastest_text + ".\n";
    t += "\nThe identified stage is a linear model: the stage's hysteresis is in the measured figures, not in the "
         "predicted ones.\n\nThe chosen controller is in controller.json (e in µm -> u in V; `error_per_um` 1); "
         "scenario.json is the identified stage with it as case `commissioned` (`piezoloop sim --scenario "
         "scenario.json --case commissioned`).\n\n" + kept + "\n";
    return t;
}

}  // namespace

nlohmann::json run_commission_session(hostlink::Client* board, const CommissionSession& a,
                                      const std::function<void(const std::string&)>& progress,
                                      const std::function<bool()>& stop_requested) {
    const auto t0 = std::chrono::steady_clock::now();
    // A simulated stage has no recording to interrupt: a stop ends the run
    // at its next step or around its figures, which take longer than the
    // steps (a board's stops its recording).
    const auto stop_point = [&] {
        if (!board && stop_requested && stop_requested()) throw std::runtime_error("stopped before the end");
    };
    const std::function<void(const std::string&)> say = [&](const std::string& line) {
        if (progress) progress(line);
        stop_point();
    };
    std::unique_ptr<commission::StageAccess> stage;
    json source;
    // The verification's triangles and recordings change the board's
    // trajectory and recorder groups; the user's are put back (before a
    // save), as the measurement sessions do (an unconfigured recorder
    // reports its defaults, which are put back).
    std::optional<link::TrajectoryParams> trajectory;
    std::optional<link::RecorderParams> recorder;
    // A board of axes: the axis commissioned (the others hold with their
    // own controllers).
    const auto axis = static_cast<uint8_t>(board ? resolve_axis(a.axis, board->axis_count(), false) : 0);
    auto put_back = [&] {
        if (trajectory) board->set(*trajectory, axis);
        if (recorder) board->set(*recorder);
    };
    if (board) {
        trajectory = board->get<link::TrajectoryParams>(axis);
        recorder = board->get<link::RecorderParams>();
        hostlink::MeasureOptions o;
        o.axis = axis;
        o.stop_requested = stop_requested;
        o.progress = a.recording_progress;
        stage = std::make_unique<CommissionedStage>(std::make_unique<hostlink::BoardStage>(*board, o), "--device");
        source = {{"kind", "board"}, {"device", board->address()}, {"board", board->info().board.data()}};
        if (board->axis_count() > 1) source["axis"] = axis_name(axis);
    } else {
        sim::Scenario s = sim::load_scenario(a.scenario);
        source = {{"kind", "simulator"}, {"scenario", s.name}, {"case", ""}};
        if (s.multi_axis()) {
            if (a.axis.empty())
                throw std::invalid_argument("--axes: the scenario's stage has coupled axes; commission them with --axes " +
                                            sim::axis_names(s, ","));
            s = sim::axis_alone(s, sim::axis_named(s, a.axis, "--axes"));
            source["axis"] = a.axis;
        } else if (!a.axis.empty()) {
            throw std::invalid_argument("--axes: the scenario's stage has one axis (leave --axes out)");
        }
        stage = std::make_unique<CommissionedStage>(std::make_unique<commission::SimStage>(s), "--scenario");
    }
    commission::Commissioning c;
    try {
        c = commission::commission(*stage, a.request, say);
    } catch (...) {
        // Whatever stopped it, a board is left disarmed (the measurement
        // sessions put its groups back).
        if (board) try {
                board->disarm();
                put_back();
            } catch (const std::exception&) {
            }
        throw;
    }
    if (board) put_back();
    const double rate_Hz = stage->loop().rate_Hz;
    std::string kept = "Nothing was kept: the simulator has no storage.";
    if (c.chosen >= 0 && !c.verified()) {
        kept = "Not kept: the verification failed (" + c.verification_failure + ").";
    } else if (board && c.chosen >= 0) {
        if (!a.save) {
            kept = "Loaded, not saved: the board forgets it at its next boot.";
        } else {
            board->save();
            kept = "Saved on the board (`save`): applied, disarmed, at its next boot.";
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
                          std::string(c.verification.empty() ? "" : ", verification.png (tracking, measured and predicted; "
                                                                    "the closed loop's response)") +
                          ".";
    stop_point();
    try {
        sim::plot_spec("plot_sim.py", commission::commission_figures(c, std::filesystem::absolute(dir)));
    } catch (const std::exception& e) {
        figures = std::string("The figures could not be drawn: ") + e.what();
        say("warning: " + figures);
    }
    stop_point();
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
    out["hysteresis"] = c.hysteresis_note;
    json safety = json::array();
    for (const auto& st : c.safety)
        safety.push_back({{"step_V", st.step_V}, {"from_V", st.from_V}, {"dy_um", st.dy_um}, {"noise_um", st.noise_um},
                          {"gain_um_per_V", st.gain_um_per_V}});
    out["safety"] = safety;
    json fits = json::array();
    for (std::size_t i = 0; i < c.fits.size(); ++i)
        fits.push_back({{"order", std::to_string(c.fits[i].poles) + "/" + std::to_string(c.fits[i].zeros)},
                        {"rms_rel", c.fits[i].rms_rel},
                        {"dc_gain_um_per_V", c.fits[i].dc_gain_um_per_V},
                        {"chosen", static_cast<int>(i) == c.chosen_fit}});
    out["fits"] = fits;
    out["log"] = c.log;
    if (c.uncertainty)
        out["uncertainty_weight"] = {{"r0", c.uncertainty->r0},
                                     {"corner_Hz", c.uncertainty->wz_rad_s / (2.0 * std::numbers::pi)},
                                     {"uncovered_lines", c.uncertainty->uncovered_lines},
                                     {"w3", design::to_json(c.uncertainty->w3)}};
    json cands = json::array();
    for (const auto& k : c.candidates) cands.push_back(candidate_json(k));
    out["candidates"] = cands;
    if (c.through_inverse) out["through_inverse"] = through_inverse_json(*c.through_inverse, c.candidates);
    out["chosen"] = c.chosen >= 0 ? json(c.candidates[static_cast<std::size_t>(c.chosen)].name) : json();
    out["report"] = (dir / "report.md").string();
    out["verified"] = c.verified();
    if (c.chosen >= 0) {
        const auto& k = c.candidates[static_cast<std::size_t>(c.chosen)];
        // null where |T| stays above -3 dB over the whole band measured
        // (bandwidth_above_Hz: the band's top).
        out["bandwidth_Hz"] = c.measured_bandwidth_Hz > 0.0 || !c.closed_frf ? json(c.measured_bandwidth_Hz) : json();
        if (c.measured_bandwidth_Hz == 0.0 && c.closed_frf)
            out["bandwidth_above_Hz"] = c.closed_frf->estimate.frequency_Hz.back();
        out["bandwidth_from_open_loop_Hz"] = c.bandwidth_Hz;
        json v = json::array();
        for (const auto& r : c.verification)
            v.push_back({{"frequency_Hz", r.request.frequency_Hz},
                         {"range_um", r.request.range_um},
                         {"measured", tracking_json(r.measured)},
                         {"predicted", tracking_json(r.predicted)}});
        out["verification"] = v;
        if (c.fastest)
            out["fastest_triangle"] = {{"within_pct", c.fastest->tolerance_pct},
                                     {"up_to_Hz", c.fastest->up_to_Hz},
                                     {"at_least", c.fastest->at_least},
                                     {"text", c.fastest_text}};
        if (!c.verified()) out["verification_failure"] = c.verification_failure;
        json m = design::to_json(k.controller);
        m["description"] = "commissioned by piezoloop commission on " + stage->describe() + ": " + k.name + " (" +
                           k.method + "); e (um) -> u (V)" +
                           (k.feedforward || k.prefilter ? "; the feedforward and pre-filter are in scenario.json "
                                                           "(case commissioned)"
                                                         : "");
        write("controller.json", m.dump(1) + "\n");
        write("scenario.json", commission::commissioned_scenario(c).dump(1) + "\n");
        out["controller_file"] = (dir / "controller.json").string();
        out["scenario_file"] = (dir / "scenario.json").string();
    }
    if (board) out["saved"] = c.verified() && a.save;
    out["wall_s"] = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
    return out;
}

}  // namespace piezoloop::cli
