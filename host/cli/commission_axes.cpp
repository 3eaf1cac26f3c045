#include "commission_axes.hpp"

#include <algorithm>
#include <cmath>
#include <filesystem>
#include <fstream>
#include <set>
#include <sstream>
#include <stdexcept>

#include "commission_session.hpp"
#include "format/number.hpp"
#include "json/json_reader.hpp"
#include "measure/coupling.hpp"
#include "measure/mimo_frf_sim.hpp"
#include "measure/static_decoupling.hpp"
#include "sim/multi_axis_sim_case.hpp"
#include "sim/scenario.hpp"
#include "synth/plant_json.hpp"

namespace piezoloop::cli {
namespace {

using nlohmann::json;


// Low-frequency coupling per pair "y<-x" (output <- input), dB.
json pair_db(const std::vector<std::string>& names, const measure::Coupling& c) {
    json j = json::object();
    for (const measure::CouplingPair& p : c.pairs)
        j[names[static_cast<std::size_t>(p.output)] + "<-" + names[static_cast<std::size_t>(p.input)]] = p.low_frequency_db;
    return j;
}

std::string joined(const std::vector<std::string>& names, const char* separator) {
    std::string all;
    for (const std::string& n : names) all += (all.empty() ? "" : separator) + n;
    return all;
}

}  // namespace

std::map<std::string, double> axes_ranges(const AxesCommission& a, const std::vector<std::string>& names,
                                          const std::string& what) {
    const auto index = [&](const std::string& name, const char* option) {
        const auto it = std::find(names.begin(), names.end(), name);
        if (it == names.end())
            throw std::invalid_argument(std::string(option) + ": \"" + name + "\" is not an axis of " + what +
                                        " (axes: " + joined(names, ", ") + ")");
        return static_cast<std::size_t>(it - names.begin());
    };
    // Every axis, once: the decoupling is over the whole stage.
    std::vector<std::string> axes = a.axes;
    if (axes == std::vector<std::string>{"all"}) axes = names;
    std::set<std::size_t> seen;
    for (const std::string& name : axes)
        if (!seen.insert(index(name, "--axes")).second)
            throw std::invalid_argument("--axes: \"" + name + "\" is named twice");
    if (seen.size() != names.size())
        throw std::invalid_argument("--axes: name every axis of " + what + " (" + joined(names, ",") +
                                    "): they are decoupled together");
    std::map<std::string, double> range_um;
    for (const auto& [name, r] : a.range_um) range_um[names[index(name, "--range-um")]] = r;
    for (const std::string& x : names) {
        if (!range_um.count(x) && a.range_every_um > 0.0) range_um[x] = a.range_every_um;
        const auto r = range_um.find(x);
        if (r == range_um.end() || !(r->second > 0.0))
            throw std::invalid_argument("--range-um: no range > 0 for axis " + x + " (give one for all, or NAME=UM each)");
    }
    return range_um;
}

json coupling_change(const std::vector<std::string>& names, const measure::MimoFrfEstimate& eb,
                     const measure::MimoFrfEstimate& ea, bool& decoupled) {
    const measure::Coupling cb = measure::coupling(eb.frequency_Hz, eb.response);
    const measure::Coupling ca = measure::coupling(ea.frequency_Hz, ea.response);
    json reduction = json::object(), unmeasured = json::object();
    decoupled = true;
    for (std::size_t k = 0; k < cb.pairs.size(); ++k) {
        const measure::CouplingPair& p = cb.pairs[k];
        const std::string pair = names[static_cast<std::size_t>(p.output)] + "<-" + names[static_cast<std::size_t>(p.input)];
        double snr_db = 0.0;
        for (const int l : cb.low_lines) snr_db += eb.snr_db[static_cast<std::size_t>(l)](p.output, p.input);
        snr_db /= static_cast<double>(cb.low_lines.size());
        const double r = p.low_frequency_db - ca.pairs[k].low_frequency_db;
        reduction[pair] = r;
        if (snr_db < kMeasuredSnr_dB)
            unmeasured[pair] = "at the noise floor (SNR " + format::significant(snr_db, 3) + " dB at the low lines): no coupling to remove";
        else
            decoupled = decoupled && r >= kRequiredReduction_dB;
    }
    std::vector<double> low_Hz;
    for (const int l : cb.low_lines) low_Hz.push_back(eb.frequency_Hz[static_cast<std::size_t>(l)]);
    return {{"low_frequency_lines_Hz", low_Hz},
            {"before_db", pair_db(names, cb)},
            {"after_db", pair_db(names, ca)},
            {"reduction_db", reduction},
            {"not_measured", unmeasured},
            {"required_reduction_db", kRequiredReduction_dB}};
}

std::string axes_table_md(const std::vector<std::string>& names, const std::map<std::string, double>& range_um,
                          const json& per_axis) {
    std::ostringstream md;
    md << "| axis | range (um) | chosen | verified | bandwidth (Hz) | whole-range triangle within 1 % up to (Hz) | report |\n"
          "|---|---|---|---|---|---|---|\n";
    for (const std::string& x : names) {
        const json& r = per_axis[x];
        md << "| " << x << " | " << format::significant(range_um.at(x), 4) << " | "
           << (r["chosen"].is_string() ? r["chosen"].get<std::string>() : std::string("none")) << " | "
           << (r.value("verified", false) ? "yes" : "no") << " | "
           << (r.contains("bandwidth_Hz") && r["bandwidth_Hz"].is_number()
                   ? format::significant(r["bandwidth_Hz"].get<double>(), 4)
               : r.contains("bandwidth_above_Hz")
                   ? "> " + format::significant(r["bandwidth_above_Hz"].get<double>(), 4)
                   : std::string("-"))
           << " | "
           << (r.contains("fastest_triangle")
                   ? (r["fastest_triangle"].value("at_least", false) ? ">= " : "") +
                         format::significant(r["fastest_triangle"]["up_to_Hz"].get<double>(), 3)
                   : std::string("-"))
           << " | " << x << "/report.md |\n";
    }
    return md.str();
}

std::string cross_motion_table_md(const json& checks) {
    std::ostringstream md;
    md << "| driven | e_max (%) | held axis | cross motion with D (%) | without D (%) |\n|---|---|---|---|---|\n";
    for (const auto& [name, c] : checks.items())
        for (const auto& [held, pct] : c["cross_motion_pct"].items())
            md << "| " << name << " | " << format::significant(c["e_max_pct"].get<double>(), 4) << " | " << held << " | "
               << format::significant(pct.get<double>(), 4) << " | "
               << format::significant(c["cross_motion_pct_without_decoupling"][held].get<double>(), 4) << " |\n";
    return md.str();
}

std::string coupling_table_md(const json& coupling) {
    std::ostringstream md;
    md << "\nLow-frequency coupling (mean over the lines at ";
    const json& low = coupling["low_frequency_lines_Hz"];
    for (std::size_t k = 0; k < low.size(); ++k) md << (k ? ", " : "") << format::significant(low[k].get<double>(), 4);
    md << " Hz), open loop, before and after the output matrix D = G0^-1 diag(G0):\n\n"
          "| pair | before (dB) | after (dB) | reduction (dB) |\n|---|---|---|---|\n";
    for (const auto& [pair, db] : coupling["before_db"].items())
        md << "| " << pair << " | " << format::significant(db.get<double>(), 4) << " | "
           << format::significant(coupling["after_db"][pair].get<double>(), 4) << " | "
           << format::significant(coupling["reduction_db"][pair].get<double>(), 4)
           << (coupling["not_measured"].contains(pair) ? " (" + coupling["not_measured"][pair].get<std::string>() + ")"
                                                        : std::string())
           << " |\n";
    return md.str();
}

json run_axes_commission(const AxesCommission& a, const std::function<void(const std::string&)>& progress,
                         const std::function<bool()>& stop_requested) {
    auto say = [&](const std::string& line) {
        if (progress) progress(line);
    };
    const sim::Scenario s = sim::load_scenario(a.scenario);
    if (!s.multi_axis()) throw std::invalid_argument("--axes: the scenario's stage has one axis (leave --axes out)");
    std::vector<std::string> names;
    for (const sim::AxisSpec& x : s.axes) names.push_back(x.name);
    const std::map<std::string, double> range_um = axes_ranges(a, names, "the stage");
    const std::filesystem::path dir(a.out);
    std::filesystem::create_directories(dir);

    // 1. Each axis alone.
    json per_axis = json::object();
    bool verified = true;
    std::map<std::string, double> centre_um;
    for (const sim::AxisSpec& x : s.axes) {
        CommissionSession cs;
        cs.scenario = a.scenario;
        cs.axis = x.name;
        cs.out = (dir / x.name).string();
        cs.request = a.request;
        cs.request.range_um = range_um.at(x.name);
        say(x.name + ": commissioning over " + format::significant(cs.request.range_um, 4) + " um, the other axes holding still");
        const json r = run_commission_session(
            nullptr, cs, [&](const std::string& line) { say(x.name + ": " + line); }, stop_requested);
        per_axis[x.name] = r;
        centre_um[x.name] = r.value("centre_um", 0.0);
        verified = verified && r.value("verified", false);
    }
    json out;
    out["scenario"] = s.name;
    out["axes"] = per_axis;
    out["verified"] = verified;
    if (!verified) {
        out["decoupled"] = false;
        out["failure"] = "an axis failed its verification (its report.md in " + dir.string() + "/<axis> says why): "
                         "nothing was decoupled";
        return out;
    }

    // 2. The coupled stage's response and its static decoupling.
    const double span_V = s.limits.u_max_V - s.limits.u_min_V;
    const measure::MimoFrfRequest fr =
        measure::mimo_request(s, kFrfFrom_Hz, kFrfTo_Hz, kFrfAmplitude * span_V,
                              {0.5 * (s.limits.u_min_V + s.limits.u_max_V)}, kFrfPeriods, 1);
    say("coupling: measuring the " + std::to_string(s.axes.size()) + " x " + std::to_string(s.axes.size()) +
        " response, " + format::significant(kFrfFrom_Hz, 4) + " to " + format::significant(kFrfTo_Hz, 4) + " Hz");
    const measure::MimoFrfSimRun before = measure::run_mimo_frf_sim(s, fr);
    const measure::MimoFrfEstimate& eb = before.estimate;
    const measure::StaticDecoupling d = measure::static_decoupling(eb.frequency_Hz, eb.response);

    // 3. Through the output matrix.
    say("coupling: measuring again through the decoupling output matrix");
    const measure::MimoFrfSimRun after = measure::run_mimo_frf_sim(s, fr, d.output_matrix);
    bool decoupled = true;
    out["coupling"] = coupling_change(names, eb, after.estimate, decoupled);
    out["coupling"]["static_gain"] = design::matrix_json(d.g0);
    out["coupling"]["condition_1"] = d.condition_1;
    out["output_matrix"] = design::matrix_json(d.output_matrix);
    out["decoupled"] = decoupled;

    // 4. The coupled stage with the commissioned controllers.
    json scenario = hostjson::read_file(a.scenario);
    json axes_controllers = json::object();
    for (const sim::AxisSpec& x : s.axes) {
        const json axis_scenario = hostjson::read_file((dir / x.name / "scenario.json").string());
        for (const json& c : axis_scenario.at("cases"))
            if (c.at("name") == "commissioned") axes_controllers[x.name] = c.at("controller");
    }
    json with_d = {{"axes", axes_controllers}, {"output_matrix", design::matrix_json(d.output_matrix)}};
    scenario["cases"] = json::array(
        {{{"name", "commissioned"},
          {"label", "commissioned axis by axis, decoupled by the measured static gain"},
          {"controller", with_d}},
         {{"name", "commissioned_without_decoupling"},
          {"label", "commissioned axis by axis, no output matrix"},
          {"controller", {{"axes", axes_controllers}}}}});
    scenario.erase("experiments");
    const sim::Scenario coupled = sim::parse_scenario(scenario, std::filesystem::absolute(a.scenario).parent_path());

    json checks = json::object();
    for (std::size_t i = 0; i < s.axes.size(); ++i) {
        const std::string& name = s.axes[i].name;
        say("check: a " + format::significant(kCheckFrequency_Hz, 4) + " Hz triangle over " + format::significant(range_um.at(name), 4) + " um on " + name +
            ", the other axes holding their centres");
        json check;
        for (const char* case_name : {"commissioned", "commissioned_without_decoupling"}) {
            sim::MultiAxisSimRequest m;
            m.sim.case_name = case_name;
            m.sim.frequency_Hz = kCheckFrequency_Hz;
            m.sim.amplitude_um = range_um.at(name);
            m.sim.midpoint_um = centre_um.at(name);
            m.axis = name;
            for (const sim::AxisSpec& other : s.axes)
                if (other.name != name) m.holds.push_back(other.name + "=" + std::to_string(centre_um.at(other.name)));
            m.check_realisation = false;
            const sim::MultiAxisSimPlan plan = sim::plan_multi_axis_sim(coupled, m);
            const sim::MultiAxisRunResult run = sim::run_multi_axis(plan.model, plan.options);
            const json summary = sim::multi_axis_sim_summary(coupled, m, plan, run);
            const bool decoupling = std::string(case_name) == "commissioned";
            if (decoupling) {
                check["e_max_pct"] = summary["e_max_pct"];
                check["e_rms_pct"] = summary["e_rms_pct"];
                check["cross_motion_pct"] = summary["cross_motion_pct"];
                check["log_hash"] = summary["log_hash"];
            } else {
                check["cross_motion_pct_without_decoupling"] = summary["cross_motion_pct"];
            }
        }
        checks[name] = check;
    }
    out["check"] = {{"frequency_Hz", kCheckFrequency_Hz}, {"axes", checks}};

    const std::filesystem::path scenario_file = dir / "scenario.json";
    {
        std::ofstream f(scenario_file);
        if (!(f << scenario.dump(1) << "\n")) throw std::runtime_error("--out: cannot write " + scenario_file.string());
    }
    std::ostringstream md;
    md << "# Commissioning of " << s.name << ", axis by axis\n\n";
    md << axes_table_md(names, range_um, per_axis);
    md << coupling_table_md(out["coupling"]);
    md << "\nA " << format::significant(kCheckFrequency_Hz, 4)
       << " Hz triangle over each axis's range, the others holding their centres (scenario.json, case "
          "commissioned; cross motion in % of the driven axis's range):\n\n"
       << cross_motion_table_md(checks);
    {
        std::ofstream f(dir / "report.md");
        if (!(f << md.str())) throw std::runtime_error("--out: cannot write " + (dir / "report.md").string());
    }
    out["scenario_file"] = scenario_file.string();
    out["report"] = (dir / "report.md").string();
    return out;
}

}  // namespace piezoloop::cli
