// PI composition (docs/models.md, 'Analytic PI inverse') on the simulator:
// a stage whose hysteresis differs from
// the model its inverse was computed from (the kind of mismatch an
// identification leaves), driven by that inverse alone, outputs
//     y = rho r + Xi,   |Xi| <= sum_j |p_eta_j| r_eta_j
// with rho and the bound from the design toolkit (analysis/pi_composition),
// which computes them from the two models without simulating.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstdio>

#include <nlohmann/json.hpp>

#include "analysis/pi_composition.hpp"
#include "piezoloop/pi_inverse.hpp"
#include "piezoloop/reference_stage.hpp"
#include "sim/build_case.hpp"
#include "sim/experiments.hpp"
#include "sim/scenario.hpp"

using namespace piezoloop;
using namespace piezoloop::sim;

namespace {

nlohmann::json pi_json(const PiModel& m) {
    nlohmann::json r = nlohmann::json::array(), w = nlohmann::json::array();
    for (int j = 0; j < m.count; ++j) {
        r.push_back(m.thresholds[static_cast<size_t>(j)]);
        w.push_back(m.weights[static_cast<size_t>(j)]);
    }
    return {{"kind", "pi"}, {"thresholds_V", r}, {"weights_um_per_V", w}, {"p0_um_per_V", m.p0}};
}

// An ideal stage (no dynamics, converters or noise) with `hysteresis` and
// one case, "inverse": its pi_inverse feedforward alone.
nlohmann::json ideal_scenario_json(const nlohmann::json& hysteresis) {
    return {{"scenario", "composition"},
            {"loop", {{"rate_Hz", 100000}, {"position_full_scale_um", 64}, {"voltage_full_scale_V", 16},
                      {"hard_limits", {{"u_min_V", -10}, {"u_max_V", 10}, {"slew_V_per_s", 1e6}}}}},
            {"plant", {{"dac", {{"bits", 0}, {"min", -10}, {"max", 10}}},
                       {"amplifier", {{"gain", 1}, {"input_min_V", -10}, {"input_max_V", 10}, {"output_min_V", -10},
                                      {"output_max_V", 10}}},
                       {"hysteresis", hysteresis},
                       {"sensor", {{"gain_per_um", 1}}},
                       {"adc", {{"bits", 0}, {"min", -100}, {"max", 100}}}}},
            {"reference", {{"nominal_um_per_V", 4.4}, {"offset", "bipolar"}}},
            {"cases", {{{"name", "inverse"}, {"controller", {{"feedforward", {{"kind", "pi_inverse"}}}}}}}}};
}

// The published 15-operator model (inverse computed from it) and a stage
// with 5 % more linear weight and 10 % less play weight; an ideal stage
// unless `with_dynamics`.
Scenario composition_scenario(bool with_dynamics) {
    nlohmann::json j = ideal_scenario_json(pi_json(reference::stage_model()));
    j["cases"][0]["plant"] = {{"hysteresis", pi_json(reference::true_stage_model())}};
    if (with_dynamics)
        j["plant"]["dynamics"] = {{"model", "models/janaideh2016_D.json"}, {"normalise_dc", true}};
    return parse_scenario(j, std::string(PIEZOLOOP_GOLDEN_DIR) + "/../../configs");
}

// Two periods of a sine of range_um peak to peak at f_Hz, from rest, every
// tick logged.
RunResult run_sine(const LoopModel& m, double rate_Hz, double f_Hz, double range_um) {
    TrajectoryRequest t;
    t.waveform = Waveform::kSine;
    t.frequency_Hz = f_Hz;
    t.range_um = range_um;
    t.unipolar = false;
    t.periods = 2;
    RunOptions o = plan_run(rate_Hz, t, 0, false);
    o.log_start = 0;
    o.log_every = 1;
    return run_loop(m, o);
}

struct Check {
    double rho = 0.0, bound = 0.0, worst_xi = 0.0;
};

// Runs a 40 um p-p sine (first cycle from rest, so the plays start at zero
// as the theorem assumes) and returns the largest |y - rho r| from `skip_s`
// on (the stage's dynamics ring after the start).
Check run(bool with_dynamics, double f_Hz, double skip_s) {
    const Scenario s = composition_scenario(with_dynamics);
    PiModel inverse{};
    EXPECT_TRUE(invert_pi(reference::stage_model(), inverse).ok());
    const design::PiComposition comp = design::compose_pi(reference::true_stage_model(), inverse);
    EXPECT_TRUE(comp.monotone);
    BuildOptions bo;
    bo.check_realisation = false;
    const BuiltCase b = build_case(s, s.cases.front(), bo);
    const RunResult r = run_sine(b.model, s.rate_Hz, f_Hz, 40.0);
    Check c{comp.rho, comp.xi_bound, 0.0};
    // log: r_k and the reading y_k of tick k (the response to u_{k-1});
    // compare y_{k+1} with r_k.
    for (size_t k = static_cast<size_t>(skip_s * s.rate_Hz); k + 1 < r.log.r_um.size(); ++k)
        c.worst_xi = std::max(c.worst_xi, std::fabs(static_cast<double>(r.log.y_um[k + 1]) - comp.rho * r.log.r_um[k]));
    return c;
}

}  // namespace

TEST(SimComposition, InverseCompensatedOutputIsRhoTimesInputPlusBoundedXi) {
    // Ideal stage: y_{k+1} is the hysteresis of u_k exactly; the only slack
    // is float rounding of the two 15-operator sums (~1e-5 um at 20 um).
    const Check c = run(false, 1.0, 0.0);
    std::printf("rho %.5f, bound on Xi %.4f um, largest |y - rho r| %.4f um\n", c.rho, c.bound, c.worst_xi);
    EXPECT_LE(c.worst_xi, c.bound + 1e-4);
    // Not a vacuous bound: the mismatch makes Xi use a good part of it.
    EXPECT_GT(c.worst_xi, 0.1 * c.bound);
    EXPECT_GT(std::fabs(c.rho - 1.0), 1e-3);
}

TEST(SimComposition, HoldsWithTheStageDynamicsAtLowFrequency) {
    // With D(s): at 0.1 Hz its phase lag is ~1e-3 rad, i.e. ~0.02 um of a
    // 20 um amplitude, and the float stage's DC gain error ~0.1 % (its
    // slowest pole pair, |z| = 0.993 at 100 kHz, rounded to float32): 0.1 um
    // of slack.
    // The start excites D(s)'s 595 Hz mode (zeta 0.007, decay time 36 ms):
    // compared from 1 s on.
    const Check c = run(true, 0.1, 1.0);
    std::printf("with D(s): largest |y - rho r| %.4f um (bound %.4f um)\n", c.worst_xi, c.bound);
    EXPECT_LE(c.worst_xi, c.bound + 0.1);
}

TEST(SimComposition, PiInverseOfAStageWithAnOutputMapPutsTheMapsInverseFirst) {
    // A stage y = S(PI[v]) (a modified PI: S flattens above 5 and 12 um) and
    // the case's `pi_inverse` of it: S^-1 on r, then the PI inverse. On the
    // ideal stage y_{k+1} is r_k but for float rounding through S^-1, the
    // inverse's and the model's 15 operators and S (~1e-5 um at 20 um);
    // the plain inverse of the same stage misses by S's bend (> 1 um).
    const PiModel model = reference::stage_model();
    auto scenario = [&](bool with_map) {
        nlohmann::json h = pi_json(model);
        if (with_map) h["output_map"] = {{"thresholds_um", {5.0, 12.0}}, {"weights", {-0.2, -0.3}}};
        return parse_scenario(ideal_scenario_json(h), ".");
    };
    auto worst = [](const Scenario& plant, const Scenario& inverse_of) {
        BuildOptions bo;
        bo.check_realisation = false;
        BuiltCase b = build_case(plant, plant.cases.front(), bo);
        const BuiltCase inv = build_case(inverse_of, inverse_of.cases.front(), bo);
        b.model.params = inv.model.params;  // the inverse computed for `inverse_of`'s stage
        const RunResult r = run_sine(b.model, plant.rate_Hz, 1.0, 30.0);
        double w = 0.0;
        for (size_t k = 0; k + 1 < r.log.r_um.size(); ++k)
            w = std::max(w, std::fabs(static_cast<double>(r.log.y_um[k + 1]) - r.log.r_um[k]));
        return w;
    };
    const Scenario with_map = scenario(true), without = scenario(false);
    const double exact = worst(with_map, with_map), plain = worst(with_map, without);
    std::printf("output map: largest |y - r| %.2e um with S^-1 in the inverse, %.3f um without\n", exact, plain);
    EXPECT_LT(exact, 1e-4);
    EXPECT_GT(plain, 1.0);
}
