#include "ui/scan_job.hpp"

#include <cmath>
#include <optional>
#include <string>
#include <tuple>
#include <utility>

#include "scan/scan_case.hpp"
#include "ui/field_refusal.hpp"
#include "ui/form_number.hpp"

namespace piezoloop::ui {

using nlohmann::json;

namespace {

std::pair<double, double> two(const json& v, const std::string& field) {
    if (!v.is_array() || v.size() != 2) throw FieldRefusal(field, field + ": must be two numbers");
    return {form_number(v[0], field), form_number(v[1], field)};
}

// The plan's messages name the command line's options (as `piezoloop
// scan` prints them), renamed to the form's fields.
constexpr std::pair<const char*, const char*> kScanFields[] = {
    {"--pattern", "pattern"},     {"--size-um", "size_um"},       {"--pixels", "pixels"},
    {"--line-rate-hz", "line_rate_Hz"}, {"--frames", "frames"}, {"--sample", "sample"},
    {"--centre-um", "centre_um"}, {"--retrace-speed", "retrace_speed"}, {"--scenario", "scenario"}};

FieldRefusal refusal(const std::string& message) { return renamed_refusal(message, kScanFields); }

}  // namespace

MeasurementJob::Work scan_work(BoardSession& board, const std::string& scenario, const json& form) {
    if (!form.is_object()) throw FieldRefusal("", "the request must be a JSON object");
    scan::ScanRequest r;
    bool restart_stage = false;
    for (auto it = form.begin(); it != form.end(); ++it) {
        const std::string& k = it.key();
        const json& v = it.value();
        if (k == "pattern") {
            if (!v.is_string()) throw FieldRefusal(k, "pattern: must be raster, spiral, lissajous or cycloid");
            r.pattern = v.get<std::string>();
        } else if (k == "size_um") {
            std::tie(r.size_x_um, r.size_y_um) = two(v, k);
        } else if (k == "pixels") {
            if (!v.is_array() || v.size() != 2) throw FieldRefusal(k, "pixels: must be two whole numbers");
            r.pixels_x = form_whole(v[0], k, 1e6);
            r.pixels_y = form_whole(v[1], k, 1e6);
        } else if (k == "line_rate_Hz") {
            r.line_rate_Hz = form_number(v, k);
        } else if (k == "frames") {
            r.frames = form_whole(v, k, 1e6);
        } else if (k == "sample") {
            if (!v.is_string()) throw FieldRefusal(k, "sample: must be a text such as grating:pitch=2,height_nm=50");
            r.sample = v.get<std::string>();
        } else if (k == "centre_um") {
            if (!v.is_null()) r.centre_um = two(v, k);
        } else if (k == "restart_stage") {
            if (!v.is_boolean()) throw FieldRefusal(k, "restart_stage: must be true or false");
            restart_stage = v.get<bool>();
        } else {
            throw FieldRefusal("", k + ": unknown field (pattern, size_um, pixels, line_rate_Hz, frames, sample, "
                                       "centre_um, restart_stage)");
        }
    }
    std::optional<sim::Scenario> stage;
    if (!scenario.empty()) stage = sim::load_scenario(scenario);
    // The plan against the board before anything moves (scan_on_board plans
    // again, identically, when it runs).
    try {
        board.plan_scan(r, stage ? &*stage : nullptr, scan::option_name);
    } catch (const std::invalid_argument& e) {
        throw refusal(e.what());
    }
    return [&board, r, stage, restart_stage, form](const MeasurementJob::Context& job) {
        hostlink::BoardScan b;
        try {
            b = board.scan(r, stage ? &*stage : nullptr, scan::option_name, restart_stage, job.stop_requested,
                           [&job](uint64_t k, uint64_t total) {
                               job.report("scanning", total ? static_cast<double>(k) / static_cast<double>(total) : 1.0);
                           });
        } catch (const hostlink::DeviceError& e) {
            if (e.field() == "flags" && restart_stage)
                throw FieldRefusal("restart_stage", std::string("the board refused: ") + e.what());
            throw;
        } catch (const std::invalid_argument& e) {
            throw refusal(e.what());
        }
        json out = b.outcome.figures;
        out["request"] = form;
        out["complete"] = b.problems.empty() && b.outcome.run.complete;
        json images = json::object();
        for (const scan::ScanImageSpec& im : b.outcome.images) images[im.file_stem] = scan::image_json(im);
        out["images"] = images;
        if (!b.problems.empty()) job.note("incomplete:" + b.problems);
        return out;
    };
}

}  // namespace piezoloop::ui
