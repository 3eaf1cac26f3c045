#include "synth/musyn_report.hpp"

#include <chrono>
#include <numbers>
#include <stdexcept>

#include "analysis/loop_report.hpp"
#include "analysis/mu.hpp"
#include "lti/model_json.hpp"
#include "synth/plant_json.hpp"
#include "numeric_constants.hpp"

namespace piezoloop::design {

using nlohmann::json;

namespace {

json peak_json(const MuPeak& p) {
    return {{"value", report_number(p.value)},
            {"w_rad_s", report_number(p.w_rad_s)},
            {"hz", report_number(p.w_rad_s / kTwoPi)}};
}

}  // namespace

MusynReport musyn_report(const MusynProblem& pb, const MusynNames& names, const MusynSettings& s,
                         const std::function<void(const DkRecord&)>& on_iteration) {
    if (s.iterations < 1 || s.iterations > 20) throw std::invalid_argument("--iterations: must be in [1, 20]");
    if (s.d_order < 0 || s.d_order > 12) throw std::invalid_argument("--d-order: must be in [0, 12]");
    if (!(s.gamma_tol >= 1e-12 && s.gamma_tol <= 0.1)) throw std::invalid_argument("--gamma-tol: must be in [1e-12, 0.1]");
    if (!(s.backoff >= 0.0 && s.backoff <= 1.0)) throw std::invalid_argument("--backoff: must be in [0, 1]");
    const auto t0 = std::chrono::steady_clock::now();
    MusynOptions o;
    o.iterations = s.iterations;
    o.d_order = s.d_order;
    o.hinf.rel_tol = s.gamma_tol;
    o.hinf.backoff = s.backoff;
    o.on_iteration = on_iteration;
    MusynReport rep;
    rep.result = musyn(pb, o);
    const MusynResult& r = rep.result;
    MuLoopModels m;
    m.plant = pb.plant;
    m.controller = r.controller_zpk;
    m.hm = pb.hm;
    m.w1 = pb.w1;
    m.has_w3 = pb.w3.has_value();
    if (pb.w3) m.w3 = *pb.w3;
    m.has_w2 = pb.w2.has_value();
    if (pb.w2) m.w2 = *pb.w2;
    const MuLoopResult mu = mu_loop(m);
    rep.rp_peak = mu.rp.value;
    const double seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();

    json its = json::array();
    for (const DkRecord& k : r.records)
        its.push_back({{"iteration", k.iteration},
                       {"gamma", report_number(k.gamma)},
                       {"mu_peak", report_number(k.mu_peak)},
                       {"mu_peak_hz", report_number(k.mu_peak_w_rad_s / kTwoPi)},
                       {"controller_order", k.controller_order},
                       {"plant_order", k.plant_order},
                       {"d_scaling", to_json(k.d_used)},
                       {"d_fit_max_rel_error", k.d_fit_max_rel_error},
                       {"seconds", k.seconds}});
    json& out = rep.json;
    out["command"] = "musyn";
    out["plant_file"] = names.plant;
    out["weights"] = {{"w1", names.w1}, {"hm", names.hm}, {"w2", pb.w2 ? json(names.w2) : json(nullptr)},
                      {"w3", pb.w3 ? json(names.w3) : json(nullptr)}};
    out["gamma"] = r.gamma;
    out["stable"] = r.stable && mu.nominally_stable;
    out["order"] = r.order;
    out["plant_order"] = r.plant_order;
    out["best_iteration"] = r.records[static_cast<std::size_t>(r.best)].iteration;
    out["stop_reason"] = r.stop_reason;
    out["iterations"] = its;
    out["rs_peak"] = peak_json(mu.rs);
    out["np_peak"] = peak_json(mu.np);
    out["rp_peak"] = peak_json(mu.rp);
    out["rp_peak_lower"] = report_number(mu.rp.lower);
    out["seconds"] = seconds;
    out["controller"] = to_json(r.controller_zpk);
    out["controller_ss"] = state_space_json(r.controller);
    return rep;
}

}  // namespace piezoloop::design
