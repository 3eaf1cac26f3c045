#include "sim/coupled_stage_build.hpp"

#include <string>

#include "sim/build_case.hpp"
#include "sim/design_bridge.hpp"
#include "status_text.hpp"

namespace piezoloop::sim {

namespace {

// The core's "axis[i]..." / "coupling[k]..." as the scenario's field path.
std::string scenario_text(const Scenario& s, const Status& st) {
    std::string text = describe(st);
    for (size_t i = 0; i < static_cast<size_t>(kMaxStageAxes); ++i) {
        const std::string core = "axis[" + std::to_string(i) + "]";
        if (text.rfind(core, 0) == 0)
            return (s.axes.empty() ? std::string("plant") : s.axes[i].path) + text.substr(core.size());
    }
    for (size_t k = 0; k < s.coupling.size(); ++k) {
        const std::string core = "coupling[" + std::to_string(k) + "]";
        if (text.rfind(core, 0) == 0) return s.coupling[k].path + text.substr(core.size());
    }
    return "plant." + text;
}

}  // namespace

std::vector<SosSection> coupling_sections(const CouplingSpec& c, double rate_Hz) {
    const bool advance = c.discretisation != "tustin";
    return discretise_sos(coupling_model(c), rate_Hz, c.discretisation, 0.0, advance, c.path, kMaxCouplingSections);
}

CoupledStageConfig coupled_stage_config(const Scenario& s) {
    CoupledStageConfig c{};
    if (s.axes.empty()) {
        c.axes = 1;
        c.axis[0] = float_stage_config(s.plant, s.plant.hysteresis, s.rate_Hz);
    } else {
        if (s.axes.size() > static_cast<size_t>(kMaxStageAxes) || s.coupling.size() > static_cast<size_t>(kMaxCouplingPaths))
            throw ScenarioError("plant.axes: at most 3 axes and 6 coupling paths");
        c.axes = static_cast<int>(s.axes.size());
        for (size_t i = 0; i < s.axes.size(); ++i)
            c.axis[i] = float_stage_config(s.axes[i].plant, s.axes[i].plant.hysteresis, s.rate_Hz);
        c.paths = static_cast<int>(s.coupling.size());
        for (size_t k = 0; k < s.coupling.size(); ++k) {
            const CouplingSpec& p = s.coupling[k];
            const std::vector<SosSection> sos = coupling_sections(p, s.rate_Hz);
            CouplingPath& q = c.coupling[k];
            q.from = p.from_axis;
            q.to = p.to_axis;
            q.sections = static_cast<int>(sos.size());
            for (size_t m = 0; m < sos.size(); ++m) q.filter[m] = sos[m];
        }
    }
    CoupledStage probe;
    if (const Status st = probe.configure(c); !st.ok()) throw ScenarioError(scenario_text(s, st));
    return c;
}

}  // namespace piezoloop::sim
