#include "analysis/mu_report.hpp"

#include <chrono>
#include <numbers>
#include <stdexcept>
#include <string>
#include <utility>

#include "analysis/loop_report.hpp"
#include "numeric_constants.hpp"

namespace piezoloop::design {

using nlohmann::json;

MuReport mu_report(const MuLoopModels& m) {
    for (const auto& [z, name] : {std::pair{&m.controller, "controller"}, std::pair{&m.hm, "hm"},
                                  std::pair{&m.w1, "w1"}, std::pair{&m.w3, "w3"}, std::pair{&m.w2, "w2"}}) {
        if ((z == &m.w3 && !m.has_w3) || (z == &m.w2 && !m.has_w2)) continue;
        if (z->ts != m.plant.ts)
            throw std::invalid_argument(std::string(name) +
                                        ": models must all be continuous or share the plant's ts (or give --ts)");
    }
    const auto t0 = std::chrono::steady_clock::now();
    MuReport rep;
    rep.result = mu_loop(m);
    const MuLoopResult& r = rep.result;
    const double seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();

    json perf = json::array({"w1 e"});
    if (m.has_w3) perf.push_back("w3 y");
    if (m.has_w2) perf.push_back("w2 u");
    json& out = rep.json;
    out["ts"] = m.plant.ts;
    out["nominally_stable"] = r.nominally_stable;
    out["poles_max"] = report_number(r.stability_measure);
    out["performance_outputs"] = perf;
    out["rs_peak"] = report_number(r.rs.value);
    out["rs_peak_hz"] = report_number(r.rs.w_rad_s / kTwoPi);
    out["np_peak"] = report_number(r.np.value);
    out["np_peak_hz"] = report_number(r.np.w_rad_s / kTwoPi);
    out["rp_peak"] = report_number(r.rp.value);
    out["rp_peak_hz"] = report_number(r.rp.w_rad_s / kTwoPi);
    out["rp_peak_lower"] = report_number(r.rp.lower);
    out["rp_max_relative_gap"] = report_number(r.max_gap);
    out["robustly_stable"] = r.nominally_stable && r.rs.value < 1.0;
    out["nominal_performance"] = r.nominally_stable && r.np.value < 1.0;
    out["robust_performance"] = r.nominally_stable && r.rp.value < 1.0;
    out["grid_points"] = r.points.size();
    out["seconds"] = seconds;
    out["meaning"] =
        "rs: |H_m T|; np: sqrt(|W1 S|^2 + |W3 T|^2 + |W2 KS|^2); rp: mu upper bound of N for "
        "diag(Delta 1x1, Delta_P 1xp); each < 1 (with a nominally stable loop) passes";
    if (!r.nominally_stable) out["note"] = "the nominal loop is unstable: the mu figures do not certify anything";
    return rep;
}

}  // namespace piezoloop::design
