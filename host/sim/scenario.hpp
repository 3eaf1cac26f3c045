// Scenario files (configs/*.json, format in configs/scenarios.md): a
// Hammerstein stage (DAC, amplifier, hysteresis, linear dynamics, sensor,
// ADC), the controller cases of a source, and its experiments. Parsing
// validates everything and names the offending field path, e.g.
// "cases[2].controller.rc.k_rc: must be in (0, 2)".
#pragma once

#include <filesystem>
#include <optional>
#include <string>
#include <vector>

#include <nlohmann/json.hpp>

#include "lti/lti.hpp"
#include "piezoloop/pipeline.hpp"
#include "piezoloop/stage_model.hpp"
#include "sim/closed_loop.hpp"
#include "json/json_reader.hpp"

namespace piezoloop::sim {

// Scenario files are read with the host's JSON reader: every error is a
// ScenarioError whose message starts with the field path.
using hostjson::Field;
using ScenarioError = hostjson::JsonError;

// A continuous (or discrete) linear model read from a model file or inline,
// in the design toolkit's JSON model format.
struct LinearSpec {
    design::Zpk zpk;
    std::string source;  // file it came from, or "inline"
    std::string path;    // field path (for messages)
};

// Static hysteresis of the stage, piezo voltage (V) -> displacement (µm).
// Every kind is also held in the factored form used to invert it:
//   f = in_gain * v + in_offset,   x = out_gain * plain(f)
// with `plain` a plain PI model (input gain 1, offset 0).
struct HysteresisSpec {
    std::string kind = "none";  // none | pi | shan_pi | dahl
    HysteresisKind core = HysteresisKind::kNone;
    PiModel pi{};               // pi, shan_pi: the model as the stage runs it
    DahlParams dahl{};          // dahl
    double gain_um_per_V = 1.0; // none
    PiModel plain{};            // pi, shan_pi (factored form)
    OutputMap output_map{};     // pi: S on the model's output (count 0: none)
    double in_gain = 1.0, in_offset = 0.0, out_gain = 1.0;
    std::string path;
};

struct PlantSpec {
    ConverterConfig dac{};
    AmplifierConfig amplifier{};
    HysteresisSpec hysteresis{};
    std::optional<LinearSpec> dynamics;  // continuous, normalised to unit DC gain if asked
    std::string discretisation = "zoh";  // float fidelity: zoh | tustin | matched
    SensorConfig sensor{};               // with offset, gain error, mains pickup
    ConverterConfig adc{};
    CreepConfig creep{};                 // on the hysteresis output (off: 0 % per decade)
    float drift_um_per_s = 0.0f;         // thermal drift of the displacement
};

// One axis of a stage of coupled axes (plant.axes[]): its name and the
// single-axis plant's fields.
struct AxisSpec {
    std::string name;
    PlantSpec plant;
    std::string path;  // e.g. "plant.axes[1]"
};

// A coupling path between two axes (plant.coupling[]), continuous, from the
// displacement of axis `from` to the position of axis `to` (µm/µm):
//   C(s) = dc_gain w^2 / (s^2 + 2 damping w s + w^2),   w = 2 pi mode_Hz,
// discretised at the loop rate like the plant's dynamics (docs/models.md,
// 'Coupled axes').
struct CouplingSpec {
    std::string from, to;     // axis names
    int from_axis = 0, to_axis = 0;  // their indices in Scenario::axes
    double dc_gain = 0.0;
    double mode_Hz = 0.0;
    double damping = 0.0;
    std::string discretisation = "zoh";  // zoh | tustin | matched
    std::string path;         // e.g. "plant.coupling[0]"
};

// The continuous C(s) of a coupling path.
design::Zpk coupling_model(const CouplingSpec& c);

struct DahlIdentifySpec {
    double frequency_Hz = 10.0;
    std::vector<double> amplitudes_V;  // peak-to-peak piezo voltage of each triangle, from 0
    int cycles = 3;
    double gamma_a = 30.0;
    int decimate = 5;
};

struct FeedforwardSpec {
    std::string kind = "none";  // none | gain | pi_inverse | pi_compensator | dahl
    double V_per_um = 0.0;      // gain
    std::string of = "base";    // pi_inverse: base | plant (the case's plant)
    std::string placement = "feedforward";  // pi_inverse: feedforward | series (kPiSeries)
    PiModel pi{};               // pi_compensator: r (µm) -> u (V)
    std::optional<DahlParams> dahl;  // dahl with given parameters
    std::optional<DahlIdentifySpec> identify;  // dahl identified from the plant's loops
    std::string path;
};

struct FeedbackSpec {
    std::string kind = "none";  // none | pid | lti
    double error_per_um = 1.0;  // the controller's error unit per µm (e.g. sensor V/µm)
    PidConfig pid{};            // in the controller's units (gains scaled at build)
    std::optional<LinearSpec> model;  // lti: continuous controller, error unit -> V
    std::string method = "tustin";    // lti: tustin | zoh | matched
    double prewarp_Hz = 0.0;
    std::string path;
};

struct RcSpec {
    bool enabled = false;
    int period_samples = 0;  // 0: rate / reference frequency
    RepetitiveConfig rc{};
    std::string path;
};

struct CaseSpec {
    std::string name, label;
    // Where its controller's fields are ("cases[1].controller", or one axis's
    // "cases[1].controller.axes.y"), for the messages of build_case.
    std::string controller_path;
    SampleType sample = SampleType::kFloat;
    std::optional<HysteresisSpec> plant_hysteresis;  // overrides the scenario's
    std::optional<LinearSpec> prefilter;  // continuous reference pre-filter, µm -> µm (Tustin at the loop rate)
    FeedforwardSpec feedforward;
    FeedbackSpec feedback;
    RcSpec rc;
    std::string note;
    std::string path;
    // A stage of coupled axes (Scenario::axes): every axis's controller, in
    // the order of plant.axes (each a CaseSpec of its own, its controller
    // fields above; the case's sample type and plant override are copied),
    // and the case's matrices (empty: identity, zero offsets). A controller
    // without "axes" is every axis's.
    std::vector<CaseSpec> axis_cases;
    std::vector<std::vector<double>> output_matrix;  // rows: channels; columns: axis commands
    std::vector<std::vector<double>> input_matrix;   // rows: axis positions; columns: readings (µm)
    std::vector<double> input_offset_um;             // per axis position
};

struct ExperimentSpec {
    std::string name, kind, title, note;  // kind: loops | tracking | bode | steps | growth
    std::vector<std::string> cases;
    Waveform waveform = Waveform::kTriangle;
    std::string waveform_name = "triangle";
    std::vector<double> frequencies_Hz;  // tracking, bode (one entry for loops)
    std::vector<double> amplitudes_V;    // loops: peak-to-peak piezo voltage
    std::vector<double> amplitudes_um;   // loops/tracking: peak-to-peak displacement
    std::string offset = "unipolar";     // unipolar (from 0 up) | bipolar (around 0)
    int periods = 2;                     // simulated periods; the last is measured
    double min_duration_s = 0.0;         // at least this long (RC convergence)
    std::vector<double> steps_um;        // steps: levels, each held hold_s
    double hold_s = 0.01;
    std::string path;
};

struct Scenario {
    std::string name, title, source;
    std::vector<std::string> notes;
    std::filesystem::path file;
    double rate_Hz = 100000.0;
    PipelineSetup setup{};
    LimitsConfig limits{};
    // The single-axis plant; for plant.axes, a copy of axes[0]'s (the
    // single-axis commands refuse two or three axes: require_single_axis).
    PlantSpec plant;
    std::vector<AxisSpec> axes;          // plant.axes (empty: a single-axis plant)
    std::vector<CouplingSpec> coupling;  // plant.coupling
    double nominal_um_per_V = 1.0;  // piezo V -> µm at the loading curve's mean slope
    std::string offset = "unipolar";
    std::vector<CaseSpec> cases;
    std::vector<ExperimentSpec> experiments;

    const CaseSpec& find_case(const std::string& name) const;  // throws ScenarioError
    // Command (V) -> µm at the mean slope: nominal_um_per_V * amplifier gain.
    double command_um_per_V() const { return nominal_um_per_V * plant.amplifier.gain; }
    // Two or three axes (plant.axes with more than one entry). One entry is
    // a single-axis plant written as a list: `plant` is that axis.
    bool multi_axis() const { return axes.size() > 1; }
};

// Refuses a multi-axis scenario in a command that runs single-axis stages:
// std::invalid_argument "multi-axis scenario: <command> runs single-axis
// stages only so far".
void require_single_axis(const Scenario& s, const std::string& command);

// Axis `axis` of a stage of coupled axes as a single-axis scenario of its
// own plant (plant.axes[axis] alone, no coupling path, the same loop and
// cases). With the other axes holding still this is exactly what that axis
// sees: a coupling path adds the other axes' motion to its position, and
// nothing of its motion comes back through them.
Scenario axis_alone(const Scenario& s, std::size_t axis);

// plant.axes' names, joined by `separator` ("x, y, z").
std::string axis_names(const Scenario& s, const char* separator = ", ");

// The index of the axis named `name` in plant.axes; std::invalid_argument
// "<option>: ..." naming the axes otherwise.
std::size_t axis_named(const Scenario& s, const std::string& name, const std::string& option);

// One hysteresis object (the plant's, or a case's override).
HysteresisSpec parse_hysteresis(const Field& f);

// Parses and validates; model files are resolved relative to `base_dir`.
Scenario parse_scenario(const nlohmann::json& j, const std::filesystem::path& base_dir);
// Reads the file (errors name the file for I/O and JSON syntax problems).
Scenario load_scenario(const std::filesystem::path& file);

}  // namespace piezoloop::sim
