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
#include "measure/coupling_report.hpp"
#include "measure/mimo_frf_file.hpp"

namespace piezoloop::cli {
namespace {

using nlohmann::json;

struct CouplingArgs {
    std::string file;
    std::optional<double> below_Hz;
};

void run_coupling(const CouplingArgs& a) {
    const measure::MimoFrfEstimate e = measure::load_mimo_frf_file(a.file);
    json out;
    try {
        out = measure::coupling_report(e, a.below_Hz);
    } catch (const std::invalid_argument& x) {
        const std::string what = x.what();
        throw std::invalid_argument(what.rfind("below_Hz", 0) == 0 ? "--below-hz" + what.substr(8) : a.file + ": " + what);
    }
    out["file"] = a.file;
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
const bool registered_analyze_coupling = register_command(33, add_analyze_coupling);

}  // namespace
}  // namespace piezoloop::cli
