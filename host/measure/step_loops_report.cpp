#include "measure/step_loops_report.hpp"

#include <algorithm>
#include <stdexcept>

#include "analysis/loop_report.hpp"
#include "format/number.hpp"

namespace piezoloop::measure {

using nlohmann::json;

StepRequest step_request(const StepInput& o, const MeasureBounds& b, std::optional<double> board_setpoint_um) {
    const bool has_um = o.step_um.has_value(), has_v = o.step_V.has_value();
    if (has_um == has_v) throw std::invalid_argument("--step-um: give exactly one of --step-um (closed loop) and --step-v (open loop)");
    const std::string mode = o.mode.empty() ? (has_um ? "closed" : "open") : o.mode;
    if (mode != "open" && mode != "closed") throw std::invalid_argument("--mode: must be open or closed");
    StepRequest r;
    r.closed = mode == "closed";
    if (r.closed && !has_um) throw std::invalid_argument("--step-v: closed loop steps the reference: give --step-um");
    if (!r.closed && !has_v) throw std::invalid_argument("--step-um: open loop steps the command: give --step-v");
    if (r.closed && o.bias_V) throw std::invalid_argument("--bias-v: open loop only; closed loop starts from --from-um");
    if (!r.closed && o.from_um) throw std::invalid_argument("--from-um: closed loop only; open loop starts from --bias-v");
    r.step = r.closed ? *o.step_um : *o.step_V;
    r.duration_s = o.duration_s;
    if (r.closed && o.from_um) {
        r.from = *o.from_um;
    } else if (r.closed && board_setpoint_um) {
        r.from = *board_setpoint_um;
    } else if (r.closed) {
        // 10 % into the range the loop can hold, clear of the ADC's end.
        r.from = b.closed_range.min_um + 0.1 * (b.closed_range.max_um - b.closed_range.min_um);
    } else {
        r.from = o.bias_V ? *o.bias_V : std::max(0.0, static_cast<double>(b.limits.u_min_V));
    }
    return r;
}

json step_report(const StepRequest& r, const StepRun& run, const json& source) {
    const StepFigures& f = run.figures;
    json out;
    out["mode"] = r.closed ? "closed" : "open";
    out["step"] = {{"size", r.step}, {"from", r.from}, {"unit", r.closed ? "um (reference)" : "V (command)"}};
    out["initial_um"] = f.initial;
    out["final_value_um"] = f.final_value;
    out["overshoot_pct"] = f.overshoot_pct;
    out["peak_um"] = f.peak;
    out["peak_time_s"] = f.peak_time_s;
    out["rise_time_s"] = design::report_number(f.rise_time_s);
    out["settling_time_s"] = design::report_number(f.settling_time_s);
    out["settled"] = f.settled;
    out["definitions"] = {
        {"initial_um", "mean of the recorded samples before the step"},
        {"final_value_um", "mean of the last 10 % of the samples after the step"},
        {"overshoot_pct", "(peak - final) / (final - initial) x 100, 0 if no overshoot"},
        {"rise_time_s", "10 % to 90 % of final - initial, first crossings, interpolated"},
        {"settling_time_s", "after the step, the time from which y stays within 2 % of final - initial of final"}};
    out["time_s"] = run.time_s;
    out["reference_um"] = run.r_um;
    out["command_V"] = run.u_V;
    out["response_um"] = run.y_um;
    out["units"] = {{"time", "s, 0 at the tick the step is applied"},
                    {"reference", "um"},
                    {"command", "V at the amplifier input, after the limiter"},
                    {"response", "um, the sensor's reading / its gain, as the controller used it"}};
    out["source"] = source;
    out["clipped_samples"] = run.clipped_samples;
    out["limiter_trip"] = run.trip;
    out["warnings"] = run.warnings;
    out["log_hash"] = format::hex64(run.log_hash);
    out["wall_s"] = run.wall_s;
    return out;
}

LoopsRequest loops_request(const std::vector<double>& amplitudes_V, std::optional<double> base_V,
                           double frequency_Hz, int cycles, const std::string& shape, const MeasureBounds& b) {
    LoopsRequest r;
    r.amplitudes_V = amplitudes_V;
    r.base_V = base_V ? *base_V : std::max(0.0, static_cast<double>(b.limits.u_min_V));
    r.frequency_Hz = frequency_Hz;
    r.cycles = cycles;
    r.shape = shape;
    return r;
}

json loops_report(const LoopsRequest& r, const LoopsRun& run, const json& source) {
    json loops = json::array();
    for (const LoopFigures& f : run.loops)
        loops.push_back({{"amplitude_V", f.amplitude_V},
                         {"hysteresis_pct", f.hysteresis_pct >= 0 ? json(f.hysteresis_pct) : json()},
                         {"max_width_pct", f.max_width_pct >= 0 ? json(f.max_width_pct) : json()},
                         {"y_min_um", f.y_min_um},
                         {"y_max_um", f.y_max_um}});
    json out;
    out["loops"] = loops;
    out["shape"] = r.shape;
    out["base_V"] = r.base_V;
    out["frequency_Hz"] = r.frequency_Hz;
    out["cycles"] = r.cycles;
    out["samples"] = run.y_um.size();
    out["definitions"] = {
        {"hysteresis_pct", "last cycle of the amplitude: |y_up - y_down| at the input's midpoint / (y_max - y_min) "
                           "x 100 (Ahmad2020 eq. 25-26, as piezoloop sim reports it)"},
        {"max_width_pct", "last cycle: the widest |y_up - y_down| at a common input / (y_max - y_min) x 100"},
        {"columns", "t (s), u = v (command, V, after the limiter), y = x (displacement read at the next tick, um), "
                    "amplitude_V (the loop the sample belongs to)"}};
    out["source"] = source;
    out["clipped_samples"] = run.clipped_samples;
    out["limiter_trip"] = run.trip;
    out["warnings"] = run.warnings;
    out["log_hash"] = run.log_hash != 0 ? json(format::hex64(run.log_hash)) : json();
    out["wall_s"] = run.wall_s;
    return out;
}

void write_step_csv(std::ostream& out, const StepRun& run) {
    out << "t,r,u,y\n";
    for (std::size_t i = 0; i < run.y_um.size(); ++i)
        out << format::significant(run.time_s[i], 9) << ',' << format::significant(run.r_um[i], 9) << ','
            << format::significant(run.u_V[i], 9) << ',' << format::significant(run.y_um[i], 9) << '\n';
}

void write_loops_csv(std::ostream& out, const LoopsRun& run) {
    out << "t,u,y,v,x,amplitude_V\n";
    for (std::size_t i = 0; i < run.y_um.size(); ++i) {
        const std::string u = format::significant(run.u_V[i], 9), y = format::significant(run.y_um[i], 9);
        out << format::significant(run.time_s[i], 9) << ',' << u << ',' << y << ',' << u << ',' << y << ','
            << format::significant(run.amplitude_V[i], 9) << '\n';
    }
}

}  // namespace piezoloop::measure
