// `piezoloop analyze mu`: robust stability, nominal and robust performance
// of a SISO loop by the structured singular value (host/analysis/mu.hpp,
// docs/mu.md).
//
//   analyze mu --plant G.json --controller K.json --hm Hm.json --w1 We.json
//              [--w3 Wy.json] [--w2 Wu.json] [--ts T] [--csv FILE] [--table]
//
// G_p = G (1 + Δ H_m), |Δ| <= 1; performance outputs W1 e (and W3 y,
// W2 u) for the reference r. With --ts every (continuous) model is
// discretised by Tustin at T, as `analyze loop --rate-hz` does. JSON on
// stdout (or a table with --table); bad input: "error: <option>: <what>",
// exit code 2. Registered after `analyze` (order 31) and added to it, so
// cmd_analyze.cpp stays under the file-size limit.
#include <chrono>
#include <cmath>
#include <fstream>
#include <iomanip>
#include <iostream>
#include <memory>
#include <numbers>
#include <optional>
#include <sstream>
#include <stdexcept>
#include <string>

#include <nlohmann/json.hpp>

#include "analysis/loop_report.hpp"
#include "analysis/mu_report.hpp"
#include "commands.hpp"
#include "lti/c2d.hpp"
#include "lti/model_json.hpp"
#include "options/option_checks.hpp"
#include "numeric_constants.hpp"

namespace piezoloop::cli {
namespace {

using namespace piezoloop::design;
using nlohmann::json;

struct MuArgs {
    std::string plant, controller, hm, w1, w3, w2, csv;
    std::optional<double> ts;  // given: discretise by Tustin
    bool table = false;
};

// A model file; with ts > 0 a continuous one is discretised by Tustin.
Zpk load(const std::string& file, double ts, const char* option) {
    Zpk m;
    try {
        m = load_model_file(file);
    } catch (const std::exception& e) {  // every failure to read a model file is bad input
        throw std::invalid_argument(std::string(option) + ": " + e.what());
    }
    if (ts > 0.0) {
        if (is_discrete(m.ts)) throw std::invalid_argument(std::string(option) + ": " + file +
                                                           " is discrete; --ts discretises continuous models only");
        return tustin(m, ts);
    }
    return m;
}

void run_mu(const MuArgs& a) {
    // Piezo loops sample at 1 Hz to 1 GHz; far outside, Tustin's poles
    // (1 + pT/2) / (1 - pT/2) round to 1 (T = 1e-30) or fold every mode
    // onto Nyquist, and the figures mean nothing.
    if (a.ts) options::require_in("--ts", *a.ts, 1e-9, 1.0, "s");
    const double ts = a.ts.value_or(0.0);
    MuLoopModels m;
    m.plant = load(a.plant, ts, "plant");
    m.controller = load(a.controller, ts, "controller");
    m.hm = load(a.hm, ts, "hm");
    m.w1 = load(a.w1, ts, "w1");
    if (!a.w3.empty()) { m.w3 = load(a.w3, ts, "w3"); m.has_w3 = true; }
    if (!a.w2.empty()) { m.w2 = load(a.w2, ts, "w2"); m.has_w2 = true; }
    MuReport rep = mu_report(m);
    const MuLoopResult& r = rep.result;
    json& out = rep.json;
    const double seconds = out["seconds"].get<double>();
    if (!a.csv.empty()) {
        std::ofstream f(a.csv);
        f << "f_hz,rs,np,rp_upper,rp_lower,d_delta\n" << std::setprecision(10);
        for (const MuPoint& p : r.points)
            f << p.w_rad_s / kTwoPi << ',' << p.rs << ',' << p.np << ',' << p.rp_upper << ',' << p.rp_lower << ','
              << p.d[0] << '\n';
        if (!f) throw std::runtime_error("csv: cannot write " + a.csv);
        out["csv"] = a.csv;
    }
    if (a.table) {
        std::ostringstream t;
        t << std::setprecision(6);
        t << "measure              peak        at Hz\n";
        t << "robust stability     " << std::setw(10) << r.rs.value << "  " << r.rs.w_rad_s / kTwoPi << "\n";
        t << "nominal performance  " << std::setw(10) << r.np.value << "  " << r.np.w_rad_s / kTwoPi << "\n";
        t << "robust performance   " << std::setw(10) << r.rp.value << "  " << r.rp.w_rad_s / kTwoPi
          << "  (lower bound " << r.rp.lower << ")\n";
        t << "nominally stable: " << (r.nominally_stable ? "yes" : "no") << "; " << r.points.size()
          << " frequencies in " << std::setprecision(3) << seconds << " s\n";
        std::cout << t.str();
        return;
    }
    std::cout << out.dump(1) << "\n";
}

void add_analyze_mu(CLI::App& app) {
    CLI::App* analyze = app.get_subcommand("analyze");
    auto a = std::make_shared<MuArgs>();
    CLI::App* mu = analyze->add_subcommand(
        "mu", "Structured singular value over frequency: robust stability, nominal and robust performance peaks");
    mu->add_option("--plant", a->plant, "plant model file G (JSON)")->required();
    mu->add_option("--controller", a->controller, "controller model file K (JSON)")->required();
    mu->add_option("--hm", a->hm, "multiplicative uncertainty weight H_m (JSON): G (1 + Delta H_m)")->required();
    mu->add_option("--w1", a->w1, "performance weight on the error e (JSON), e.g. H_e")->required();
    mu->add_option("--w3", a->w3, "performance weight on the output y (JSON), e.g. H_y");
    mu->add_option("--w2", a->w2, "performance weight on the control u (JSON)");
    mu->add_option("--ts", a->ts, "discretise every continuous model by Tustin at this sample period, 1e-9 to 1 s");
    mu->add_option("--csv", a->csv, "write rs, np, rp bounds and the D scaling over the grid to this CSV");
    mu->add_flag("--table", a->table, "print a table instead of JSON");
    mu->callback([a] { guarded([&] { run_mu(*a); }); });
}

const bool registered_analyze_mu = register_command(31, add_analyze_mu);

}  // namespace
}  // namespace piezoloop::cli
