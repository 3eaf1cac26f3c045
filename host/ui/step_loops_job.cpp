#include "ui/step_loops_job.hpp"

#include <cmath>
#include <sstream>

#include "ui/form_number.hpp"

namespace piezoloop::ui {

using nlohmann::json;

namespace {

// The CLI's option names and the forms' fields.
constexpr std::pair<const char*, const char*> kStepFields[] = {
    {"--step-um", "step_um"}, {"--step-v", "step_V"},         {"--from-um", "from_um"},
    {"--bias-v", "bias_V"},   {"--duration-s", "duration_s"}, {"--mode", "mode"}};
constexpr std::pair<const char*, const char*> kLoopsFields[] = {{"--amplitudes-v", "amplitudes_V"},
                                                                {"--bias-v", "bias_V"},
                                                                {"--frequency-hz", "frequency_Hz"},
                                                                {"--cycles", "cycles"},
                                                                {"--shape", "shape"}};

std::optional<double> optional_number(const json& v, const char* field) {
    if (v.is_null()) return std::nullopt;
    return form_number(v, field);
}

bool flag(const json& v, const char* field) {
    if (!v.is_boolean()) throw FieldRefusal(field, std::string(field) + ": must be true or false");
    return v.get<bool>();
}

json source_json(BoardSession& board, const measure::MeasureBounds& b) {
    const json st = board.status_json();
    return {{"kind", "board"},
            {"device", board.address()},
            {"board", st.contains("hello") ? st["hello"].value("board", "") : ""},
            {"rate_Hz", b.rate_Hz}};
}

// The board's bounds and the plan, refused at the form's fields.
template <class F>
auto checked(F f, FieldRefusal (*refusal)(const std::string&)) {
    try {
        return f();
    } catch (const BoardBusy&) {
        throw;
    } catch (const FieldRefusal&) {
        throw;
    } catch (const std::invalid_argument& e) {
        throw refusal(e.what());
    }
}

hostlink::MeasureOptions board_options(bool restart_stage, uint8_t axis, const MeasurementJob::Context& job) {
    hostlink::MeasureOptions o;
    o.restart_stage = restart_stage;
    o.axis = axis;
    o.stop_requested = job.stop_requested;
    o.progress = [report = job.report](double x) { report(x < 1.0 ? "recording" : "analysing", x); };
    return o;
}

// The board refuses --restart-stage unless it is emulated: at that field.
template <class F>
auto on_board(bool restart_stage, F f) {
    try {
        return f();
    } catch (const hostlink::DeviceError& e) {
        if (e.field() == "flags" && restart_stage) throw FieldRefusal("restart_stage", std::string("the board refused: ") + e.what());
        throw;
    }
}

std::vector<double> doubles(const json& v) { return v.get<std::vector<double>>(); }

std::string axis_text(const json& v) {
    if (!v.is_string()) throw FieldRefusal("axis", "axis: must be x, y or z");
    return v.get<std::string>();
}

}  // namespace

StepForm parse_step_form(const json& j) {
    if (!j.is_object()) throw FieldRefusal("", "the request must be a JSON object");
    StepForm f;
    measure::StepInput& in = f.input;
    for (auto it = j.begin(); it != j.end(); ++it) {
        const std::string& k = it.key();
        const json& v = it.value();
        if (k == "step_V") in.step_V = optional_number(v, "step_V");
        else if (k == "bias_V") in.bias_V = optional_number(v, "bias_V");
        else if (k == "step_um") in.step_um = optional_number(v, "step_um");
        else if (k == "from_um") in.from_um = optional_number(v, "from_um");
        else if (k == "duration_s") in.duration_s = form_number(v, "duration_s");
        else if (k == "restart_stage") f.restart_stage = flag(v, "restart_stage");
        else if (k == "axis") f.axis = axis_text(v);
        else if (k == "mode") {
            in.mode = v.is_string() ? v.get<std::string>() : "?";
            if (in.mode != "" && in.mode != "open" && in.mode != "closed")
                throw FieldRefusal("mode", "mode: must be open or closed");
        } else {
            throw FieldRefusal("", k + ": unknown field (mode, step_V, bias_V, step_um, from_um, duration_s, restart_stage, axis)");
        }
    }
    return f;
}

LoopsForm parse_loops_form(const json& j) {
    if (!j.is_object()) throw FieldRefusal("", "the request must be a JSON object");
    LoopsForm f;
    bool amplitudes = false;
    for (auto it = j.begin(); it != j.end(); ++it) {
        const std::string& k = it.key();
        const json& v = it.value();
        if (k == "amplitudes_V") {
            if (!v.is_array()) throw FieldRefusal("amplitudes_V", "amplitudes_V: must be a list of numbers (V)");
            for (const json& a : v) f.amplitudes_V.push_back(form_number(a, "amplitudes_V"));
            amplitudes = true;
        } else if (k == "bias_V") f.bias_V = optional_number(v, "bias_V");
        else if (k == "frequency_Hz") f.frequency_Hz = form_number(v, "frequency_Hz");
        else if (k == "cycles") {
            f.cycles = form_whole(v, "cycles", 1e9);
        } else if (k == "shape") {
            f.shape = v.is_string() ? v.get<std::string>() : "";
            if (f.shape != "triangle" && f.shape != "sine") throw FieldRefusal("shape", "shape: must be triangle or sine");
        } else if (k == "restart_stage") f.restart_stage = flag(v, "restart_stage");
        else if (k == "axis") f.axis = axis_text(v);
        else throw FieldRefusal("", k + ": unknown field (amplitudes_V, bias_V, frequency_Hz, cycles, shape, restart_stage, axis)");
    }
    if (!amplitudes) throw FieldRefusal("amplitudes_V", "amplitudes_V: required");
    return f;
}

FieldRefusal step_refusal(const std::string& message) { return renamed_refusal(message, kStepFields); }
FieldRefusal loops_refusal(const std::string& message) { return renamed_refusal(message, kLoopsFields); }

MeasurementJob::Work step_work(BoardSession& board, const json& form) {
    const StepForm f = parse_step_form(form);
    const uint8_t axis = axis_field(board, f.axis);
    const measure::MeasureBounds b = checked([&] { return board.measure_bounds(axis); }, step_refusal);
    const measure::StepRequest r = checked(
        [&] {
            // A closed step starts where the board holds, as on the command line.
            std::optional<double> held;
            if (!f.input.from_um) held = board.setpoint_um(axis);
            const measure::StepRequest req = measure::step_request(f.input, b, held);
            (void)measure::plan_step(b, req);
            return req;
        },
        step_refusal);
    const json source = source_json(board, b);
    return [&board, f, r, form, source, axis](const MeasurementJob::Context& job) {
        const measure::StepRun run = on_board(f.restart_stage, [&] {
            return checked([&] { return board.measure_step(r, board_options(f.restart_stage, axis, job)); }, step_refusal);
        });
        json out = measure::step_report(r, run, source);
        out["request"] = form;
        return out;
    };
}

MeasurementJob::Work loops_work(BoardSession& board, const json& form) {
    const LoopsForm f = parse_loops_form(form);
    const uint8_t axis = axis_field(board, f.axis);
    const measure::MeasureBounds b = checked([&] { return board.measure_bounds(axis); }, loops_refusal);
    const measure::LoopsRequest r = checked(
        [&] {
            const measure::LoopsRequest req =
                measure::loops_request(f.amplitudes_V, f.bias_V, f.frequency_Hz, f.cycles, f.shape, b);
            (void)measure::plan_loops(b, req);
            return req;
        },
        loops_refusal);
    const json source = source_json(board, b);
    return [&board, f, r, form, source, axis](const MeasurementJob::Context& job) {
        const measure::LoopsRun run = on_board(f.restart_stage, [&] {
            return checked([&] { return board.measure_loops(r, board_options(f.restart_stage, axis, job)); }, loops_refusal);
        });
        json out = measure::loops_report(r, run, source);
        out["request"] = form;
        out["time_s"] = run.time_s;
        out["u_V"] = run.u_V;
        out["y_um"] = run.y_um;
        out["amplitude_V"] = run.amplitude_V;
        return out;
    };
}

std::string step_csv(const json& result) {
    if (result.is_null()) return "";
    measure::StepRun run;
    run.time_s = doubles(result["time_s"]);
    run.r_um = doubles(result["reference_um"]);
    run.u_V = doubles(result["command_V"]);
    run.y_um = doubles(result["response_um"]);
    std::ostringstream out;
    measure::write_step_csv(out, run);
    return out.str();
}

std::string loops_csv(const json& result) {
    if (result.is_null()) return "";
    measure::LoopsRun run;
    run.time_s = doubles(result["time_s"]);
    run.u_V = doubles(result["u_V"]);
    run.y_um = doubles(result["y_um"]);
    run.amplitude_V = doubles(result["amplitude_V"]);
    std::ostringstream out;
    measure::write_loops_csv(out, run);
    return out.str();
}

}  // namespace piezoloop::ui
