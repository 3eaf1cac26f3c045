#include "measure/coupling_report.hpp"

#include <cmath>
#include <stdexcept>
#include <string>

#include "measure/coupling.hpp"
#include "measure/static_decoupling.hpp"
#include "synth/plant_json.hpp"

namespace piezoloop::measure {

namespace {

using nlohmann::json;

std::string pair_name(int i, int j) { return "y" + std::to_string(i + 1) + "<-u" + std::to_string(j + 1); }

json number_or_null(double x) { return std::isfinite(x) ? json(x) : json(nullptr); }

json pairs_json(const Coupling& c) {
    json out = json::array();
    for (const CouplingPair& p : c.pairs)
        out.push_back({{"pair", pair_name(p.output, p.input)},
                       {"low_frequency_db", number_or_null(p.low_frequency_db)},
                       {"max_db", number_or_null(p.max_db)},
                       {"max_Hz", p.max_Hz}});
    return out;
}

}  // namespace

json coupling_report(const MimoFrfEstimate& e, std::optional<double> below_Hz) {
    if (e.inputs < 2)
        throw std::invalid_argument("inputs: coupling needs at least 2 axes (got " + std::to_string(e.inputs) + ")");
    if (e.outputs != e.inputs)
        throw std::invalid_argument("outputs: coupling needs as many outputs as inputs (inputs=" +
                                    std::to_string(e.inputs) + ", outputs=" + std::to_string(e.outputs) + ")");
    if (e.frequency_Hz.empty()) throw std::invalid_argument("lines: the response has none");
    if (below_Hz && (!std::isfinite(*below_Hz) || !(*below_Hz > 0.0)))
        throw std::invalid_argument("below_Hz: must be > 0 Hz");
    const Coupling c = coupling(e.frequency_Hz, e.response, below_Hz);
    const StaticDecoupling d = static_decoupling(e.frequency_Hz, e.response, below_Hz);
    json low = json::array();
    for (const int k : c.low_lines) low.push_back(e.frequency_Hz[static_cast<std::size_t>(k)]);
    json after_static = json::array();
    for (Eigen::Index i = 0; i < d.g0.rows(); ++i)
        for (Eigen::Index j = 0; j < d.g0.cols(); ++j)
            if (i != j)
                after_static.push_back({{"pair", pair_name(static_cast<int>(i), static_cast<int>(j))},
                                        {"db", number_or_null(d.static_after_db(i, j))}});
    json out;
    out["axes"] = e.inputs;
    out["lines"] = e.frequency_Hz.size();
    out["band_Hz"] = {e.frequency_Hz.front(), e.frequency_Hz.back()};
    out["low_frequency_lines_Hz"] = low;
    out["coupling"] = pairs_json(c);
    out["static_gain"] = design::matrix_json(d.g0);
    out["static_gain_condition_1"] = d.condition_1;
    out["output_matrix"] = design::matrix_json(d.output_matrix);
    out["after_static_db"] = after_static;
    out["after_lines"] = pairs_json(d.after);
    return out;
}

}  // namespace piezoloop::measure
