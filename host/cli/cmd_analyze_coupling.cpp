// `piezoloop analyze coupling FILE [--below-hz F]`: how much the axes of a
// stage move each other, from a measured n x n frequency response (a MIMO
// FRF file, host/measure/mimo_frf_file.hpp), and the static decoupling
// output matrix that removes it (host/measure/coupling.hpp,
// host/measure/static_decoupling.hpp; docs/measurement.md, "Several axes").
// JSON on stdout. Bad input (no file, a malformed one, outputs != inputs, an
// ill-conditioned static gain): "error: <file>: line L: <field>: <what>" or
// "error: <field>: <what>", exit code 2.
#include <cmath>
#include <iostream>
#include <memory>
#include <optional>
#include <string>

#include <nlohmann/json.hpp>

#include "commands.hpp"
#include "measure/coupling.hpp"
#include "measure/mimo_frf_file.hpp"
#include "measure/static_decoupling.hpp"

namespace piezoloop::cli {
namespace {

using nlohmann::json;

struct CouplingArgs {
    std::string file;
    std::optional<double> below_Hz;
};

std::string pair_name(int i, int j) { return "y" + std::to_string(i + 1) + "<-u" + std::to_string(j + 1); }

// -inf (exactly no coupling) and NaN have no JSON number: null.
json number_or_null(double x) { return std::isfinite(x) ? json(x) : json(nullptr); }

json matrix_json(const Eigen::MatrixXd& m) {
    json rows = json::array();
    for (Eigen::Index i = 0; i < m.rows(); ++i) {
        json row = json::array();
        for (Eigen::Index j = 0; j < m.cols(); ++j) row.push_back(m(i, j));
        rows.push_back(row);
    }
    return rows;
}

json pairs_json(const measure::Coupling& c) {
    json out = json::array();
    for (const measure::CouplingPair& p : c.pairs)
        out.push_back({{"pair", pair_name(p.output, p.input)},
                       {"low_frequency_db", number_or_null(p.low_frequency_db)},
                       {"max_db", number_or_null(p.max_db)},
                       {"max_Hz", p.max_Hz}});
    return out;
}

void run_coupling(const CouplingArgs& a) {
    const measure::MimoFrfEstimate e = measure::load_mimo_frf_file(a.file);
    if (e.inputs < 2) throw std::invalid_argument(a.file + ": inputs: coupling needs at least 2 axes (got 1)");
    if (e.outputs != e.inputs)
        throw std::invalid_argument(a.file + ": outputs: coupling needs as many outputs as inputs (inputs=" +
                                    std::to_string(e.inputs) + ", outputs=" + std::to_string(e.outputs) + ")");
    if (a.below_Hz && (!std::isfinite(*a.below_Hz) || !(*a.below_Hz > 0.0)))
        throw std::invalid_argument("--below-hz: must be > 0 Hz");
    measure::Coupling c;
    measure::StaticDecoupling d;
    try {
        c = measure::coupling(e.frequency_Hz, e.response, a.below_Hz);
        d = measure::static_decoupling(e.frequency_Hz, e.response, a.below_Hz);
    } catch (const std::invalid_argument& x) {
        const std::string what = x.what();
        throw std::invalid_argument(what.rfind("below_Hz", 0) == 0 ? "--below-hz" + what.substr(8) : a.file + ": " + what);
    }
    json low = json::array();
    for (const int k : c.low_lines) low.push_back(e.frequency_Hz[static_cast<std::size_t>(k)]);
    json after_static = json::array();
    for (Eigen::Index i = 0; i < d.g0.rows(); ++i)
        for (Eigen::Index j = 0; j < d.g0.cols(); ++j)
            if (i != j)
                after_static.push_back({{"pair", pair_name(static_cast<int>(i), static_cast<int>(j))},
                                        {"db", number_or_null(d.static_after_db(i, j))}});
    json out;
    out["file"] = a.file;
    out["axes"] = e.inputs;
    out["lines"] = e.frequency_Hz.size();
    out["band_Hz"] = {e.frequency_Hz.front(), e.frequency_Hz.back()};
    out["low_frequency_lines_Hz"] = low;
    out["coupling"] = pairs_json(c);
    out["static_gain"] = matrix_json(d.g0);
    out["static_gain_condition_1"] = d.condition_1;
    out["output_matrix"] = matrix_json(d.output_matrix);
    out["after_static_db"] = after_static;
    out["after_lines"] = pairs_json(d.after);
    out["meaning"] =
        "coupling y_i<-u_j = |G_ij| / |G_jj| in dB; low_frequency_db: 20 log10 of its mean over "
        "low_frequency_lines_Hz; static_gain G0 = Re(mean G over those lines); output_matrix D = G0^-1 diag(G0) "
        "maps axis commands to actuator channels (u = D v); after_static_db: the coupling of G0 D (null: exactly 0); "
        "after_lines: the coupling of G(f) D on the measured lines";
    std::cout << out.dump(1) << "\n";
}

void add_analyze_coupling(CLI::App& app) {
    CLI::App* analyze = app.get_subcommand("analyze");
    auto a = std::make_shared<CouplingArgs>();
    CLI::App* c = analyze->add_subcommand(
        "coupling", "Coupling between the axes from a measured n x n frequency response (MIMO FRF CSV): per pair "
                    "and line, the static decoupling output matrix and the coupling left after it");
    c->add_option("file", a->file, "MIMO FRF file (CSV, docs/measurement.md \"Several axes\")")->required();
    c->add_option("--below-hz,--below-Hz", a->below_Hz,
                  "the low-frequency lines are those at or below this frequency (default: the lowest 3 lines)");
    c->callback([a] { guarded([&] { run_coupling(*a); }); });
}

// After `analyze` (30), `analyze mu` (31) and `analyze measured-loop` (32).
const bool registered = register_command(33, add_analyze_coupling);

}  // namespace
}  // namespace piezoloop::cli
