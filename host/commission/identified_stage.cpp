#include "commission/identified_stage.hpp"

#include <cmath>

#include "lti/freqresp.hpp"
#include "lti/model_json.hpp"
#include "sim/pi_compensator_json.hpp"

namespace piezoloop::commission {

namespace {

// A plain PI model's thresholds and weights as two lists.
std::pair<std::vector<double>, std::vector<double>> lists(const PiModel& m) {
    std::vector<double> r, w;
    for (int j = 0; j < m.count; ++j) {
        r.push_back(m.thresholds[static_cast<unsigned>(j)]);
        w.push_back(m.weights[static_cast<unsigned>(j)]);
    }
    return {r, w};
}

}  // namespace

nlohmann::json identified_scenario_json(const IdentifiedStage& st, const std::optional<Controller>& controller) {
    using nlohmann::json;
    const double g = st.gain_um_per_V;  // the reference's mean slope, and the open loop's
    json hysteresis = {{"kind", "none"}, {"gain_um_per_V", g}};
    if (st.hysteresis) {
        const auto [r, w] = lists(*st.hysteresis);
        hysteresis = {{"kind", "pi"}, {"thresholds_V", r}, {"weights_um_per_V", w}, {"p0_um_per_V", st.hysteresis->p0}};
    }
    design::Zpk unit = st.model;
    unit.gain /= design::dc_gain(st.model);
    const double u_min = st.bounds.limits.u_min_V, u_max = st.bounds.limits.u_max_V;
    json j;
    j["scenario"] = st.name;
    j["title"] = "The stage as measured by piezoloop commission";
    j["source"] = "piezoloop commission, measured on " + st.measured_on;
    j["notes"] = json::array({std::string(st.hysteresis ? "The PI hysteresis fitted to the measured loops, then the fitted "
                                                          "linear model's dynamics. "
                                                        : "Linear: the fitted model's dynamics with the largest safety "
                                                          "step's static gain; the stage's hysteresis is not in it. ") +
                              "The amplifier is the identity and the command limits are the loop's."});
    j["loop"] = {{"rate_Hz", st.loop.rate_Hz},
                 {"position_full_scale_um", st.loop.position_full_scale_um},
                 {"voltage_full_scale_V", st.loop.voltage_full_scale_V},
                 {"hard_limits", {{"u_min_V", u_min}, {"u_max_V", u_max}, {"slew_V_per_s", st.bounds.limits.slew_V_per_s}}}};
    j["plant"] = {{"dac", {{"bits", 0}, {"min", u_min}, {"max", u_max}}},
                  {"amplifier",
                   {{"gain", 1.0}, {"input_min_V", u_min}, {"input_max_V", u_max}, {"output_min_V", u_min}, {"output_max_V", u_max}}},
                  {"hysteresis", hysteresis},
                  {"dynamics", {{"model", design::to_json(unit)}, {"normalise_dc", false}, {"discretisation", "zoh"}}},
                  {"sensor", {{"gain_per_um", 1.0}, {"noise_rms", st.noise_um}, {"seed", 1}, {"offset_um", st.offset_um}}},
                  {"adc", {{"bits", 0}, {"min", st.bounds.closed_range.min_um}, {"max", st.bounds.closed_range.max_um}}}};
    j["reference"] = {{"nominal_um_per_V", std::fabs(g)}, {"offset", "unipolar"}};
    // A scenario holds at least one case: the stage driven open loop at its DC gain.
    j["cases"] = json::array({{{"name", "open_loop"},
                               {"label", "open loop"},
                               {"controller", {{"feedforward", {{"kind", "gain"}, {"V_per_um", 1.0 / g}}}}}}});
    if (controller) {
        json k = {{"feedback",
                   {{"kind", "lti"}, {"error_per_um", 1.0}, {"model", design::to_json(controller->feedback)},
                    {"method", "tustin"}}}};
        if (controller->prefilter) k["prefilter"] = design::to_json(*controller->prefilter);
        if (controller->feedforward) {
            k["feedforward"] = sim::pi_compensator_json(*controller->feedforward);
            if (controller->series) k["feedforward"]["placement"] = "series";
        }
        j["cases"].push_back({{"name", "commissioned"},
                              {"label", "commissioned controller"},
                              {"sample", st.loop.q31 ? "q31" : "float"},
                              {"controller", k}});
    }
    return j;
}

}  // namespace piezoloop::commission
