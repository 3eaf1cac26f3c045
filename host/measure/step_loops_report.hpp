// The requests and JSON of `measure step` and `measure loops`, shared by the
// command line (cli/cmd_measure_step_loops.cpp) and the Python package
// (python/src/measure.cpp): the defaults a request takes from the stage, and
// the report each writes (docs/measurement.md).
#pragma once

#include <optional>
#include <ostream>
#include <string>
#include <vector>

#include <nlohmann/json.hpp>

#include "measure/step_loops_plan.hpp"

namespace piezoloop::measure {

// A step as asked for: exactly one of step_um (closed loop, the reference)
// and step_V (open loop, the command); mode "" follows from that one.
struct StepInput {
    std::optional<double> step_um, step_V, from_um, bias_V;
    std::string mode;
    double duration_s = 0.1;
};

// The request, its start filled in: a closed loop starts from from_um, else
// from the setpoint a board holds (board_setpoint_um), else 10 % into the
// closed-loop range; open loop from bias_V, else max(0, u_min). Throws
// std::invalid_argument naming the option (--step-um, --step-v, --bias-v,
// --from-um) for a contradictory request; plan_step checks the ranges.
StepRequest step_request(const StepInput& o, const MeasureBounds& b, std::optional<double> board_setpoint_um);

// What `measure step --out` writes: the figures with their definitions, the
// response (time_s, reference_um, command_V, response_um), the source, the
// limiter's report, the warnings and the log hash.
nlohmann::json step_report(const StepRequest& r, const StepRun& run, const nlohmann::json& source);

// The response as the CSV `measure step --csv` writes: t, r, u, y (s, um,
// V, um), 9 significant digits.
void write_step_csv(std::ostream& out, const StepRun& run);

// The loops' request; base_V defaults to max(0, u_min).
LoopsRequest loops_request(const std::vector<double>& amplitudes_V, std::optional<double> base_V,
                           double frequency_Hz, int cycles, const std::string& shape, const MeasureBounds& b);

// What `measure loops --json` writes: per amplitude its hysteresis, widest
// gap and output span, with the definitions; the samples go to the CSV.
nlohmann::json loops_report(const LoopsRequest& r, const LoopsRun& run, const nlohmann::json& source);

// The samples as the CSV `measure loops --out` writes and `identify pi`
// (columns u, y) and `identify dahl` (v, x) read: t, u, y, v, x,
// amplitude_V; u = v the command after the limiter (V), y = x the
// displacement read at the next tick (um); 9 significant digits (a float
// round-trips). Written as it is formatted: a long record would double its
// memory as one string.
void write_loops_csv(std::ostream& out, const LoopsRun& run);

}  // namespace piezoloop::measure
