#include "ui/commission_job.hpp"

#include <algorithm>
#include <cmath>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <sstream>

namespace piezoloop::ui {

using nlohmann::json;

namespace {

constexpr std::pair<const char*, const char*> kCommissionFields[] = {{"--range-um", "range_um"},
                                                                   {"--target-bandwidth-hz", "target_bandwidth_Hz"},
                                                                   {"--no-save", "save"},
                                                                   {"--scenario", "on"},
                                                                   {"--axes", "axes"}};

constexpr const char* kFigures[] = {"frf.png", "loops.png", "candidates.png", "verification.png"};

std::string fresh_directory() {
    std::string t = (std::filesystem::temp_directory_path() / "piezoloop-console-commission-XXXXXX").string();
    if (mkdtemp(t.data()) == nullptr) throw std::runtime_error("cannot create a directory for the report in " + t);
    return t;
}

std::string read_text(const std::filesystem::path& p) {
    std::ifstream f(p);
    std::ostringstream s;
    s << f.rdbuf();
    return s.str();
}

}  // namespace

CommissionForm parse_commission_form(const json& j, const std::string& scenario) {
    if (!j.is_object()) throw FieldRefusal("", "the request must be a JSON object");
    CommissionForm f;
    bool range = false;
    for (auto it = j.begin(); it != j.end(); ++it) {
        const std::string& k = it.key();
        const json& v = it.value();
        if (k == "range_um") {
            if (!v.is_number() || !(v.get<double>() > 0.0) || !std::isfinite(v.get<double>()))
                throw FieldRefusal("range_um", "range_um: must be a number > 0 (um)");
            f.request.range_um = v.get<double>();
            range = true;
        } else if (k == "target_bandwidth_Hz") {
            if (v.is_null()) continue;
            if (!v.is_number() || !(v.get<double>() >= 0.0) || !std::isfinite(v.get<double>()))
                throw FieldRefusal("target_bandwidth_Hz", "target_bandwidth_Hz: must be a number >= 0 (Hz; 0 or empty: automatic)");
            f.request.target_bandwidth_Hz = v.get<double>();
        } else if (k == "save") {
            if (!v.is_boolean()) throw FieldRefusal("save", "save: must be true or false");
            f.save = v.get<bool>();
        } else if (k == "axis") {
            if (!v.is_string()) throw FieldRefusal("axis", "axis: must be x, y or z");
            f.axis = v.get<std::string>();
        } else if (k == "axes") {
            // "all" or the axes' names, each commissioned (cli::axes_ranges
            // checks them against the stage's).
            if (v == "all") {
                f.axes = {"all"};
            } else {
                if (!v.is_array() || v.empty() || !std::all_of(v.begin(), v.end(), [](const json& a) { return a.is_string(); }))
                    throw FieldRefusal("axes", "axes: must be \"all\" or a list of axes such as [\"x\", \"y\"]");
                for (const json& a : v) f.axes.push_back(a.get<std::string>());
            }
        } else if (k == "on") {
            const std::string on = v.is_string() ? v.get<std::string>() : "";
            if (on != "board" && on != "simulator") throw FieldRefusal("on", "on: must be board or simulator");
            f.simulator = on == "simulator";
        } else {
            throw FieldRefusal("", k + ": unknown field (range_um, target_bandwidth_Hz, save, on, axis, axes)");
        }
    }
    if (!range) throw FieldRefusal("range_um", "range_um: required");
    if (!f.axes.empty() && !f.axis.empty())
        throw FieldRefusal("axis", "axis: not with axes (the stage's axes, each commissioned)");
    if (f.simulator && scenario.empty())
        throw FieldRefusal("on", "on: the simulator needs the console started with --scenario (its stage is simulated)");
    return f;
}

FieldRefusal commission_refusal(const std::string& message) { return renamed_refusal(message, kCommissionFields); }

namespace {

// report.md, the figures (in `out`, or in its AXIS/ directories for a stage
// of axes) and the request, into the result.
void attach_report(json& out, const std::string& dir, const json& form, bool simulator,
                   const std::vector<std::string>& axis_dirs) {
    out["request"] = form;
    out["on"] = simulator ? "simulator" : "board";
    out["out"] = dir;
    out["report_md"] = read_text(std::filesystem::path(dir) / "report.md");
    json figures = json::array();
    for (const std::string& prefix : axis_dirs)
        for (const char* name : kFigures)
            if (std::filesystem::exists(std::filesystem::path(dir) / prefix / name)) figures.push_back(prefix + name);
    out["figures"] = figures;
}

MeasurementJob::Work axes_commission_work(BoardSession& board, const std::string& scenario, const CommissionForm& f,
                                          const json& form) {
    cli::AxesCommission a;
    a.axes = f.axes;
    a.request = f.request;
    a.range_every_um = f.request.range_um;
    if (f.simulator) a.scenario = scenario;
    if (!f.simulator) (void)board.measure_bounds(0);  // the board is free now
    return [&board, a, f, form](const MeasurementJob::Context& job) mutable {
        a.out = fresh_directory();
        const auto note = [&](const std::string& line) {
            job.note(line);
            job.report("commissioning", 0.0);
        };
        json out;
        try {
            out = f.simulator ? cli::run_axes_commission(a, note, job.stop_requested)
                              : board.commission_axes(a, f.save, note, job.stop_requested);
        } catch (const FieldRefusal&) {
            throw;
        } catch (const std::invalid_argument& e) {
            throw commission_refusal(e.what());
        }
        std::vector<std::string> dirs;
        for (const auto& item : out["axes"].items()) dirs.push_back(item.key() + "/");
        attach_report(out, a.out, form, f.simulator, dirs);
        return out;
    };
}

}  // namespace

MeasurementJob::Work commission_work(BoardSession& board, const std::string& scenario, const json& form) {
    const CommissionForm f = parse_commission_form(form, scenario);
    if (!f.axes.empty()) return axes_commission_work(board, scenario, f, form);
    // The board must be free now (not a refusal after the click's reply).
    if (!f.simulator) (void)board.measure_bounds(axis_field(board, f.axis));
    return [&board, f, scenario, form](const MeasurementJob::Context& job) {
        cli::CommissionSession s;
        s.request = f.request;
        if (!f.simulator) s.axis = f.axis;
        s.save = f.save && !f.simulator;
        s.out = fresh_directory();
        if (f.simulator) s.scenario = scenario;
        const auto note = [&](const std::string& line) {
            job.note(line);
            job.report("commissioning", 0.0);
        };
        json out;
        try {
            if (f.simulator) {
                out = cli::run_commission_session(nullptr, s, note, job.stop_requested);
            } else {
                s.recording_progress = [&](double x) { job.report("recording", x); };
                out = board.commission(s, note, job.stop_requested);
            }
        } catch (const FieldRefusal&) {
            throw;
        } catch (const std::invalid_argument& e) {
            throw commission_refusal(e.what());
        }
        attach_report(out, s.out, form, f.simulator, {""});
        return out;
    };
}

std::string commission_figure_path(const json& result, const std::string& name) {
    if (result.is_null() || !result.contains("out") || !result.contains("figures")) return "";
    for (const json& f : result["figures"])
        if (f == name) return (std::filesystem::path(result["out"].get<std::string>()) / name).string();
    return "";
}

}  // namespace piezoloop::ui
