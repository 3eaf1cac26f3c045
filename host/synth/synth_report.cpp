// `piezoloop design hinf|mixsyn`'s report (synth_report.hpp), moved out of
// the command so the Python module gives the same JSON.
#include "synth/synth_report.hpp"

#include <cmath>
#include <stdexcept>

#include "lti/lti_convert.hpp"
#include "lti/model_json.hpp"
#include "synth/plant_json.hpp"

namespace piezoloop::design {

using nlohmann::json;

HinfOptions hinf_options(const SynthSettings& a) {
    if (!(a.gamma_tol >= 1e-12 && a.gamma_tol <= 0.1))
        throw std::invalid_argument("--gamma-tol: must be in [1e-12, 0.1]");
    if (!(a.gamma_max >= 0.0)) throw std::invalid_argument("--gamma-max: must be > 0");
    if (!(a.backoff >= 0.0 && a.backoff <= 1.0)) throw std::invalid_argument("--backoff: must be in [0, 1]");
    HinfOptions o;
    o.rel_tol = a.gamma_tol;
    o.gamma_max = a.gamma_max;
    o.backoff = a.backoff;
    return o;
}

HinfReport hinf_report(const GeneralisedPlant& p, const std::string& plant_name, const SynthSettings& s) {
    HinfReport rep;
    rep.result = hinfsyn(p, hinf_options(s));
    const HinfSynthesis& r = rep.result;
    json& out = rep.json;
    out["command"] = "hinf";
    out["plant_file"] = plant_name;
    out["gamma"] = r.gamma;
    out["stable"] = r.stable;
    out["order"] = r.controller.states();
    out["synthesis"] = synthesis_json(r, s);
    out["controller"] = state_space_json(r.controller);
    if (r.controller.inputs() == 1 && r.controller.outputs() == 1) out["controller_model"] = to_json(ss2zpk(to_siso(r.controller)));
    return rep;
}

json synthesis_json(const HinfSynthesis& r, const SynthSettings& a) {
    return {{"gamma_opt", r.gamma_opt},
            {"gamma_lower", r.gamma_lower},
            {"gamma_controller", r.gamma_controller},
            {"gamma_tol", a.gamma_tol},
            {"backoff", a.backoff},
            {"iterations", r.iterations},
            {"frequency_scale_rad_s", r.w0_rad_s},
            {"riccati",
             {{"residual_x", r.residual_x},
              {"residual_y", r.residual_y},
              {"cond_u11_x", r.cond_x},
              {"cond_u11_y", r.cond_y},
              {"rho_xy_over_gamma2", r.rho_xy_over_gamma2}}}};
}

MixsynReport mixsyn_report(const NamedModel& g, const NamedModel& w1, const std::optional<NamedModel>& w2,
                           const std::optional<NamedModel>& w3, const SynthSettings& a) {
    const HinfOptions o = hinf_options(a);
    const auto model = [](const std::optional<NamedModel>& m) { return m ? std::optional<Zpk>(m->model) : std::nullopt; };
    const MixsynResult r = mixsyn(g.model, w1.model, model(w2), model(w3), o);
    json out;
    out["command"] = "mixsyn";
    out["plant_file"] = g.name;
    out["weights"] = {{"w1", w1.name}, {"w2", w2 ? json(w2->name) : json(nullptr)}, {"w3", w3 ? json(w3->name) : json(nullptr)}};
    out["gamma"] = r.gamma;
    out["stable"] = r.stable;
    out["hinf_W1S"] = r.hinf_W1S;
    out["hinf_W2KS"] = w2 ? json(r.hinf_W2KS) : json(nullptr);
    out["hinf_W3T"] = w3 ? json(r.hinf_W3T) : json(nullptr);
    out["order"] = r.order;
    out["augmented_plant_order"] = r.plant_order;
    out["synthesis"] = synthesis_json(r.synthesis, a);
    out["controller"] = to_json(r.controller_zpk);
    out["controller_ss"] = state_space_json(r.synthesis.controller);
    return {out, r};
}

json pi_notch_json(const PiNotchDesign& d) {
    json notches = json::array();
    for (const Notch& n : d.notches)
        notches.push_back({{"f_Hz", n.f_Hz}, {"plant_damping", n.plant_damping}, {"notch_damping", n.notch_damping}});
    return {{"controller", to_json(d.controller)},
            {"kp", d.kp},
            {"integral_Hz", d.integral_Hz},
            {"target_Hz", d.target_Hz},
            {"crossover_Hz", d.crossover_Hz},
            {"notches", notches},
            {"phase_margin_deg", d.phase_margin_deg},
            {"gain_margin_db", std::isinf(d.gain_margin_db) ? json(nullptr) : json(d.gain_margin_db)},
            {"hinf_S", d.hinf_S},
            {"warnings", d.warnings}};
}

}  // namespace piezoloop::design
