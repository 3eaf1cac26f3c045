// `piezoloop identify rls|pi|dahl --data FILE.csv ...` and
// `piezoloop reduce --model M.json --order N`: identification from CSV data
// and balanced truncation (host/ident/rls, pi_fit, dahl_fit, balred). JSON
// on stdout; a bad file, column, option or unidentifiable data gives
// "error: <field>: <why>" on stderr and exit code 2; a hysteresis fit that
// misses the data by more than --max-nrmse prints its JSON with
// "poor_fit": true, says so on stderr and exits 1.
#include <unistd.h>

#include <chrono>
#include <cmath>
#include <functional>
#include <iostream>
#include <memory>
#include <stdexcept>
#include <string>
#include <vector>

#include <nlohmann/json.hpp>

#include "analysis/loop_report.hpp"
#include "commands.hpp"
#include "ident/balred.hpp"
#include "ident/csv_data.hpp"
#include "ident/dahl_fit.hpp"
#include "lti/lti_convert.hpp"
#include "lti/model_json.hpp"
#include "ident/pi_fit.hpp"
#include "ident/reduce_report.hpp"
#include "ident/rls.hpp"
#include "sim/pi_compensator_json.hpp"

namespace piezoloop::cli {
namespace {

using nlohmann::json;
namespace d = piezoloop::design;

// What a long fit is doing, on stderr once it has run for a second: a line
// rewritten in place on a terminal, else a line every 10 s.
class FitProgress {
public:
    explicit FitProgress(std::string label)
        : label_(std::move(label)), tty_(isatty(STDERR_FILENO) != 0), t0_(std::chrono::steady_clock::now()) {}
    ~FitProgress() {
        if (shown_ && tty_) std::cerr << "\n";
    }
    void operator()(const std::string& what) {
        const auto now = std::chrono::steady_clock::now();
        const double elapsed = std::chrono::duration<double>(now - t0_).count();
        const double since = std::chrono::duration<double>(now - last_).count();
        if (elapsed < 1.0 || (shown_ && since < (tty_ ? 0.5 : 10.0))) return;
        last_ = now;
        shown_ = true;
        std::cerr << (tty_ ? "\r" : "") << label_ << ": " << what << " (" << static_cast<int>(elapsed) << " s)"
                  << (tty_ ? "   " : "\n") << std::flush;
    }

private:
    std::string label_;
    bool tty_;
    bool shown_ = false;
    std::chrono::steady_clock::time_point t0_, last_;
};

// Non-finite numbers (e.g. the fit of a diverging model) as JSON null.

struct DataArgs {
    std::string file;
    std::string input;
    std::string output;
    std::string columns;  // "u=1,y=5": a headerless table, these fields
};

void add_data_options(CLI::App* cmd, DataArgs& a, const char* in_default, const char* out_default) {
    a.input = in_default;
    a.output = out_default;
    cmd->add_option("--data", a.file,
                    "CSV file with a header row naming the columns, or with --columns a headerless table")
        ->required();
    cmd->add_option("--input", a.input, "input column name")->capture_default_str();
    cmd->add_option("--output", a.output, "output column name")->capture_default_str();
    cmd->add_option("--columns", a.columns,
                    "read a headerless table (fields separated by tabs, spaces or commas) and name its fields, "
                    "counted from 1: e.g. u=1,y=5");
}

template <class Progress>
d::CsvData read_data(const DataArgs& a, Progress& progress) {
    if (a.columns.empty()) return d::read_csv(a.file, std::ref(progress));
    const std::vector<d::ColumnPick> picks = d::parse_column_picks(a.columns);
    return d::read_table(a.file, picks, std::ref(progress));
}

// Fit figures as JSON.
json errors_json(const d::FitErrors& e) {
    return {{"rms_error", e.rms_error},
            {"max_error", e.max_error},
            {"nrmse_percent", d::report_number(e.nrmse_percent)},
            {"samples", e.samples}};
}

// What a poor fit means, on stderr; the caller exits 1 after printing the JSON.
void warn_poor_fit(const std::string& model, double nrmse, double limit, bool validated) {
    std::cerr << "error: poor fit: the " << model << " misses the " << (validated ? "held-out" : "fitted")
              << " data by NRMSE " << nrmse << " % (limit " << limit
              << " %, --max-nrmse); the model is not a result to use (see docs/identification.md, "
                 "'Fit quality')\n";
}

// ---------------------------------------------------------------- rls

struct RlsArgs {
    DataArgs data;
    std::string time = "t";
    double ts = 0.0;
    std::string structure = "arx";
    d::LinearIdentSpec spec;
};

void run_rls(const RlsArgs& a) {
    FitProgress progress("identify rls");
    const d::CsvData csv = read_data(a.data, progress);
    const std::vector<double>& u = csv.column(a.data.input);
    const std::vector<double>& y = csv.column(a.data.output);
    double ts = a.ts;
    if (ts == 0.0) {
        if (!csv.has(a.time))
            throw std::invalid_argument("ts: " + a.data.file + " has no time column '" + a.time +
                                        "'; give --time NAME or --ts SECONDS");
        ts = d::uniform_sample_period(csv, a.time);
    }
    d::LinearIdentSpec spec = a.spec;
    spec.structure = a.structure == "oe" ? d::LinearStructure::kOutputError : d::LinearStructure::kArx;
    spec.input_name = a.data.input;
    spec.output_name = a.data.output;
    spec.progress = std::ref(progress);
    const d::LinearIdentResult r = d::identify_linear(u, y, ts, spec);
    json out;
    out["method"] = r.method;
    out["structure"] = a.structure;
    out["na"] = spec.na;
    out["nb"] = spec.nb;
    out["delay"] = spec.delay;
    out["forgetting"] = spec.forgetting;
    out["model"] = d::to_json(r.model);
    out["a"] = r.a;
    out["b"] = r.b;
    out["stable"] = r.stable;
    out["iterations"] = r.iterations;
    out["converged"] = r.converged;
    out["fit"] = {{"fit_percent", d::report_number(r.fit_percent)},
                  {"simulation_rms", d::report_number(r.simulation_rms)},
                  {"prediction_rms", d::report_number(r.prediction_rms)},
                  {"regressor_condition", d::report_number(r.regressor_condition)},
                  {"samples", r.samples_used}};
    std::cout << out.dump(1) << "\n";
}

void add_rls(CLI::App* parent) {
    auto a = std::make_shared<RlsArgs>();
    CLI::App* cmd = parent->add_subcommand(
        "rls",
        "Discrete linear model by recursive least squares (Ahmad2020 eq. 1-3): ARX, or output-error by "
        "Steiglitz-McBride iterations");
    add_data_options(cmd, a->data, "u", "y");
    cmd->add_option("--time", a->time, "time column (seconds), gives the sample period")->capture_default_str();
    cmd->add_option("--ts", a->ts, "sample period in seconds (instead of a time column)")
        ->check(CLI::PositiveNumber);
    cmd->add_option("--structure", a->structure, "model structure")
        ->check(CLI::IsMember({"arx", "oe"}))
        ->capture_default_str();
    cmd->add_option("--na", a->spec.na, "poles (A or F order)")->check(CLI::Range(0, 20))->capture_default_str();
    cmd->add_option("--nb", a->spec.nb, "numerator coefficients")->check(CLI::Range(1, 20))->capture_default_str();
    cmd->add_option("--delay", a->spec.delay, "input delay in samples")
        ->check(CLI::Range(0, 1000))
        ->capture_default_str();
    cmd->add_option("--forgetting", a->spec.forgetting, "RLS forgetting factor in (0, 1]")
        ->check(CLI::Range(1e-6, 1.0))
        ->capture_default_str();
    cmd->add_option("--max-iter", a->spec.max_iterations, "Steiglitz-McBride passes (oe)")
        ->check(CLI::Range(1, 10000))
        ->capture_default_str();
    cmd->callback([a] { guarded([&] { run_rls(*a); }); });
}

// ---------------------------------------------------------------- pi

struct IdentifyPiArgs {
    DataArgs data;
    std::string grid = "uniform";
    std::string first_fitted = "auto";
    bool no_offset = false;
    d::PiFitOptions options;
};

json dead_zone_json(const d::DeadZoneMap& m) {
    return {{"thresholds", m.thresholds}, {"weights", m.weights}, {"slopes", m.slopes()}};
}

// --first-fitted: 'auto' (returned as `automatic`) or a sample index.
std::size_t first_fitted_option(const std::string& text, std::size_t automatic) {
    if (text == "auto") return automatic;
    std::size_t pos = 0;
    long long v = -1;
    try {
        v = std::stoll(text, &pos);
    } catch (const std::exception&) {
        pos = 0;
    }
    if (pos != text.size() || v < 0)
        throw std::invalid_argument("first-fitted: '" + text + "' must be 'auto' or a sample index >= 0");
    return static_cast<std::size_t>(v);
}

int run_pi(const IdentifyPiArgs& a) {
    FitProgress progress("identify pi");
    const d::CsvData csv = read_data(a.data, progress);
    const std::vector<double>& u = csv.column(a.data.input);
    const std::vector<double>& y = csv.column(a.data.output);
    d::PiFitOptions o = a.options;
    o.grid = a.grid == "shan" ? d::ThresholdGrid::kShan : d::ThresholdGrid::kUniform;
    o.fit_offset = !a.no_offset;
    o.first_fitted = first_fitted_option(a.first_fitted, d::PiFitOptions::kAutoFirstFitted);
    o.input_name = a.data.input;
    o.output_name = a.data.output;
    o.progress = std::ref(progress);
    const d::PiFitResult r = d::fit_pi(u, y, o);
    json out;
    // Same layout as `piezoloop pi-inverse` takes and prints: the first
    // entry is the threshold-0 (linear) term p0.
    std::vector<double> thresholds{0.0};
    thresholds.insert(thresholds.end(), r.thresholds.begin(), r.thresholds.end());
    out["thresholds"] = thresholds;
    out["weights"] = r.weights;
    out["slopes"] = r.slopes;
    out["grid"] = o.thresholds.empty() ? a.grid : "explicit";
    out["monotone"] = o.monotone;
    if (o.monotone) out["min_slope"] = r.min_slope;
    if (o.output_dead_zones > 0) out["min_output_slope"] = o.min_output_slope;
    if (o.monotone || o.output_dead_zones > 0) out["active_constraints"] = r.active_constraints;
    out["offset_fitted"] = o.fit_offset;
    out["offset_um"] = r.offset_after_descent;
    out["rest_offset_um"] = r.offset;
    out["first_fitted"] = r.first_fitted;
    if (o.output_dead_zones > 0)
        out["output_nonlinearity"] = {{"dead_zones", o.output_dead_zones},
                                      {"inverse", dead_zone_json(r.output_inverse)},
                                      {"forward", dead_zone_json(r.output_map)}};
    else
        out["output_nonlinearity"] = nullptr;
    out["invertible"] = r.invertible;
    out["invertibility"] = r.invertibility;
    // The compensator, in the form a scenario's feedforward takes
    // (configs/scenarios.md, pi_compensator): u = PI^-1(g(r) - offset).
    out["compensator"] = r.invertible ? sim::pi_compensator_json(r.compensator()) : json(nullptr);
    json fit = errors_json({r.rms_error, r.max_error, r.nrmse_percent, r.validated_from - r.first_fitted});
    fit["regressor_condition"] = r.regressor_condition;
    out["fit"] = fit;
    out["validation"] = r.validation.samples > 0 ? errors_json(r.validation) : json(nullptr);
    out["poor_fit"] = r.poor_fit;
    out["max_nrmse_percent"] = o.max_nrmse_percent;
    std::cout << out.dump(1) << "\n";
    const bool validated = r.validation.samples > 0;
    std::cerr << "identify pi: " << (o.output_dead_zones > 0 ? "modified PI, " : "PI, ") << r.thresholds.size()
              << " operators" << (o.output_dead_zones > 0 ? ", " + std::to_string(o.output_dead_zones) + (o.output_dead_zones > 1 ? " dead zones" : " dead zone") : "")
              << "; offset " << r.offset_after_descent << " (output at input 0 after a descent)"
              << "; NRMSE " << r.nrmse_percent << " % on samples " << r.first_fitted << ".."
              << r.validated_from - 1;
    if (validated) std::cerr << ", " << r.validation.nrmse_percent << " % held out (from sample " << r.validated_from << ")";
    std::cerr << "\n";
    if (!r.invertible) std::cerr << "identify pi: not invertible: " << r.invertibility << "\n";
    if (r.poor_fit) {
        warn_poor_fit(o.output_dead_zones > 0 ? "modified PI model" : "PI model", r.judged_nrmse_percent,
                      o.max_nrmse_percent, validated);
        if (!o.fit_offset) std::cerr << "identify pi: the output offset was not fitted (--no-offset)\n";
        return kExitFailure;
    }
    return kExitOk;
}

void add_pi(CLI::App* parent) {
    auto a = std::make_shared<IdentifyPiArgs>();
    CLI::App* cmd = parent->add_subcommand(
        "pi", "Prandtl-Ishlinskii weights (and output offset) by least squares on play-operator regressors");
    add_data_options(cmd, a->data, "u", "y");
    cmd->add_option("--operators", a->options.operators, "play operators besides the linear term")
        ->check(CLI::Range(1, 16))
        ->capture_default_str();
    cmd->add_option("--grid", a->grid,
                    "thresholds: uniform (j*reach/(n+1), reach = half the input span with the offset) or shan "
                    "(rho*j, Shan2012)")
        ->check(CLI::IsMember({"uniform", "shan"}))
        ->capture_default_str();
    cmd->add_option("--rho", a->options.rho, "threshold spacing of the shan grid")->check(CLI::PositiveNumber);
    add_number_list(cmd, "--thresholds", a->options.thresholds, "explicit thresholds r1,r2,... (> 0, ascending)");
    cmd->add_flag("--monotone", a->options.monotone,
                  "constrain the loading-curve slopes P_j >= min-slope (invertible result)");
    cmd->add_option("--min-slope", a->options.min_slope,
                    "smallest slope in the monotone fit (default 1e-3 * output range / input range)");
    cmd->add_flag("--no-offset", a->no_offset, "no output offset: y = PI[u] (plays at rest at the start)");
    cmd->add_option("--first-fitted", a->first_fitted,
                    "first sample in the fit: auto (where the plays have forgotten their state before the "
                    "record) or an index (earlier samples only run the plays)")
        ->capture_default_str();
    cmd->add_option("--holdout", a->options.holdout,
                    "fraction of the record, at its end, kept out of the fit to validate it")
        ->check(CLI::Range(0.0, 0.9))
        ->capture_default_str();
    cmd->add_option("--output-nonlinearity", a->options.output_dead_zones,
                    "dead zones of a static output nonlinearity (modified PI, Kuhnen 2003); 0: plain PI")
        ->check(CLI::Range(0, 8))
        ->capture_default_str();
    cmd->add_option("--max-nrmse", a->options.max_nrmse_percent,
                    "NRMSE (%) above which the fit is flagged poor and the exit code is 1")
        ->check(CLI::PositiveNumber)
        ->capture_default_str();
    cmd->callback([a] { guarded([&] { return run_pi(*a); }); });
}

// ---------------------------------------------------------------- dahl

struct DahlArgs {
    DataArgs data;
    double gamma_a = 1.0;
    std::vector<double> start;
    int max_evaluations = 4000;
    bool no_offset = false;
    double max_nrmse_percent = 10.0;
    std::string first_fitted = "auto";
    std::string start_state = "estimated";
    double holdout = 0.0;
};

json dahl_json(const d::DahlParamsD& p) {
    return {{"alpha1", p.alpha1}, {"alpha2", p.alpha2}, {"beta1", p.beta1},
            {"beta2", p.beta2},   {"gamma_a", p.gamma_a}, {"ga", p.ga}};
}

int run_dahl(const DahlArgs& a) {
    FitProgress progress("identify dahl");
    const d::CsvData csv = read_data(a.data, progress);
    const std::vector<double>& v = csv.column(a.data.input);
    const std::vector<double>& x = csv.column(a.data.output);
    d::DahlFitOptions o;
    o.gamma_a = a.gamma_a;
    o.max_evaluations = a.max_evaluations;
    o.fit_offset = !a.no_offset;
    o.max_nrmse_percent = a.max_nrmse_percent;
    o.first_fitted = first_fitted_option(a.first_fitted, d::DahlFitOptions::kAutoFirstFitted);
    o.start_state = a.start_state == "virgin" ? d::DahlStartState::kVirgin : d::DahlStartState::kEstimated;
    o.holdout = a.holdout;
    o.input_name = a.data.input;
    o.output_name = a.data.output;
    if (!a.start.empty()) {
        if (a.start.size() != 5)
            throw std::invalid_argument("start: needs 5 values alpha1,alpha2,beta1,beta2,ga (got " +
                                        std::to_string(a.start.size()) + ")");
        o.start = d::DahlParamsD{a.start[0], a.start[1], a.start[2], a.start[3], a.gamma_a, a.start[4]};
    }
    o.progress = std::ref(progress);
    const d::DahlFitResult r = d::fit_dahl(v, x, o);
    json out;
    out["params"] = dahl_json(r.params);
    out["std_errors"] = {{"alpha1", r.std_errors[0]}, {"alpha2", r.std_errors[1]}, {"beta1", r.std_errors[2]},
                         {"beta2", r.std_errors[3]},  {"ga", r.std_errors[4]}};
    out["beta1_gamma_a"] = r.beta1_gamma_a;
    out["beta2_gamma_a"] = r.beta2_gamma_a;
    out["gamma_a_held"] = true;
    out["offset_fitted"] = o.fit_offset;
    out["offset_um"] = r.offset;
    out["first_fitted"] = r.first_fitted;
    out["start_state"] = a.start_state;
    out["virgin_V"] = r.virgin_V ? json(*r.virgin_V) : json(nullptr);
    out["virgin_V_std_error"] = r.virgin_V_std_error ? json(*r.virgin_V_std_error) : json(nullptr);
    out["fit"] = {{"rms_error", r.rms_error},
                  {"max_error", r.max_error},
                  {"nrmse_percent", r.nrmse_percent},
                  {"samples", r.fitted_samples}};
    out["validation"] = r.validation_samples > 0
                            ? errors_json({r.validation_rms_error, r.validation_max_error, r.validation_nrmse_percent,
                                           r.validation_samples})
                            : json(nullptr);
    out["poor_fit"] = r.poor_fit;
    out["max_nrmse_percent"] = o.max_nrmse_percent;
    out["lm"] = {{"termination", r.termination},
                 {"evaluations", r.evaluations},
                 {"starts", r.starts},
                 {"jacobian_condition", r.jacobian_condition}};
    std::cout << out.dump(1) << "\n";
    const bool validated = r.validation_samples > 0;
    std::cerr << "identify dahl: offset " << r.offset << " (output at voltage 0 from the virgin state)";
    if (r.virgin_V) std::cerr << "; the model starts from the virgin state at " << *r.virgin_V << " V";
    std::cerr << "; NRMSE " << r.nrmse_percent << " % on samples " << r.first_fitted << ".." << r.validated_from - 1;
    if (validated)
        std::cerr << ", " << r.validation_nrmse_percent << " % held out (from sample " << r.validated_from << ")";
    std::cerr << "\n";
    if (r.poor_fit) {
        warn_poor_fit("Dahl model", validated ? r.validation_nrmse_percent : r.nrmse_percent, o.max_nrmse_percent,
                      validated);
        return kExitFailure;
    }
    return kExitOk;
}

void add_dahl(CLI::App* parent) {
    auto a = std::make_shared<DahlArgs>();
    CLI::App* cmd = parent->add_subcommand(
        "dahl",
        "Dahl model (alpha1, alpha2, beta1, beta2, ga) by Levenberg-Marquardt; gamma_a is held (only "
        "beta*gamma_a is identifiable)");
    add_data_options(cmd, a->data, "v", "x");
    cmd->add_option("--gamma-a", a->gamma_a, "gamma_a, held during the fit")->capture_default_str();
    add_number_list(cmd, "--start", a->start, "starting point alpha1,alpha2,beta1,beta2,ga (default: grid search)");
    cmd->add_option("--max-evaluations", a->max_evaluations, "model simulations per LM run")
        ->check(CLI::Range(10, 1000000))
        ->capture_default_str();
    cmd->add_flag("--no-offset", a->no_offset, "no output offset: x = the Dahl plant's output");
    cmd->add_option("--first-fitted", a->first_fitted,
                    "first sample in the fit: auto (the input's first turning point) or an index")
        ->capture_default_str();
    cmd->add_option("--start-state", a->start_state,
                    "the model's state at the first fitted sample: estimated (from the virgin state at a fitted "
                    "voltage, moved straight there) or virgin (from the virgin state at sample 0, the samples "
                    "before the first fitted one running the model)")
        ->check(CLI::IsMember({"estimated", "virgin"}))
        ->capture_default_str();
    cmd->add_option("--holdout", a->holdout, "fraction of the record, at its end, kept out of the fit to validate it")
        ->check(CLI::Range(0.0, 0.9))
        ->capture_default_str();
    cmd->add_option("--max-nrmse", a->max_nrmse_percent,
                    "NRMSE (%) above which the fit is flagged poor and the exit code is 1")
        ->check(CLI::PositiveNumber)
        ->capture_default_str();
    cmd->callback([a] { guarded([&] { return run_dahl(*a); }); });
}

void add_identify(CLI::App& app) {
    CLI::App* cmd = app.add_subcommand("identify", "Identify models from measured or simulated CSV data");
    cmd->require_subcommand(1);
    add_rls(cmd);
    add_pi(cmd);
    add_dahl(cmd);
}

// ---------------------------------------------------------------- reduce

struct ReduceArgs {
    std::string model;
    int order = 0;
};

void run_reduce(const ReduceArgs& a) {
    std::cout << d::reduce_report(d::load_model_file(a.model), a.order).dump(1) << "\n";
}

void add_reduce(CLI::App& app) {
    auto a = std::make_shared<ReduceArgs>();
    CLI::App* cmd = app.add_subcommand(
        "reduce",
        "Balanced truncation of a stable model: Hankel singular values, reduced model, error bound "
        "2*sum(sigma_i, i > order)");
    cmd->add_option("--model", a->model, "model JSON file (num/den, zeros/poles/gain or series; optional ts)")
        ->required();
    cmd->add_option("--order", a->order, "states to keep")->required()->check(CLI::Range(1, 200));
    cmd->callback([a] { guarded([&] { run_reduce(*a); }); });
}

const bool registered_identify = register_command(50, add_identify);
const bool registered_reduce = register_command(55, add_reduce);

}  // namespace
}  // namespace piezoloop::cli
