// Scenario files (configs/*.json) and the simulator's building blocks:
// validation errors name the field path; the shipped scenarios load and every
// case builds; the streamed metrics (docs/models.md, 'Metrics') equal metrics.hpp's on the same
// samples; the double-fidelity stage against analytic responses.
#include <gtest/gtest.h>

#include <cmath>
#include <fstream>
#include <functional>
#include <numbers>
#include <random>
#include <string>

#include <nlohmann/json.hpp>

#include "lti/lti_convert.hpp"
#include "piezoloop/emulation_profile.hpp"
#include "piezoloop/reference_stage.hpp"
#include "sim/build_case.hpp"
#include "sim/metrics.hpp"
#include "sim/scenario.hpp"
#include "sim/stage_double.hpp"
#include "sim/window_metrics.hpp"
#include "status_text.hpp"

using namespace piezoloop;
using namespace piezoloop::sim;

namespace {

const std::string kConfigs = std::string(PIEZOLOOP_GOLDEN_DIR) + "/../../configs/";

nlohmann::json read(const std::string& name) {
    std::ifstream f(kConfigs + name + ".json");
    return nlohmann::json::parse(f);
}

// The message of the ScenarioError that parsing j throws ("" if none).
std::string error_of(const nlohmann::json& j) {
    try {
        (void)parse_scenario(j, kConfigs);
    } catch (const ScenarioError& e) {
        return e.what();
    }
    return "";
}

}  // namespace

TEST(SimScenario, ShippedScenariosLoadAndEveryCaseBuilds) {
    for (const char* name : {"ahmad2020", "janaideh2016", "shan2012"}) {
        const Scenario s = load_scenario(kConfigs + name + ".json");
        EXPECT_FALSE(s.experiments.empty()) << name;
        for (const ExperimentSpec& e : s.experiments)
            for (const std::string& c : e.cases)
                for (const double f : e.frequencies_Hz.empty() ? std::vector<double>{1.0} : e.frequencies_Hz) {
                    BuildOptions o;
                    o.reference_frequency_Hz = f;
                    o.check_realisation = false;
                    EXPECT_NO_THROW(build_case(s, s.find_case(c), o)) << name << " " << c << " " << f;
                }
    }
}

TEST(SimScenario, ErrorsNameTheFieldPath) {
    const nlohmann::json shan = read("shan2012");
    struct Bad {
        std::function<void(nlohmann::json&)> edit;
        std::string expect;
    };
    const Bad bad[] = {
        {[](auto& j) { j["cases"][2]["controller"]["rc"]["k_rc"] = 2.5; }, "cases[2].controller.rc.k_rc: must be in (0, 2)"},
        {[](auto& j) { j["cases"][2]["controller"]["rc"]["period_samples"] = 100; j["cases"][2]["controller"]["rc"]["m1"] = 200; }, "cases[2].controller.rc.m2: N - m1 - m2 must be >= 1"},
        {[](auto& j) { j["plant"]["sensr"] = 1; }, "plant.sensr: unknown field"},
        {[](auto& j) { j["loop"].erase("rate_Hz"); }, "loop.rate_Hz: required field is missing"},
        {[](auto& j) { j["plant"]["amplifier"]["gain"] = "x"; }, "plant.amplifier.gain: must be a number"},
        {[](auto& j) { j["plant"]["dac"]["bits"] = 30; }, "plant.dac.bits: must be an integer in [0, 24]"},
        {[](auto& j) { j["plant"]["dynamics"]["model"] = "models/no_such_model.json"; }, "plant.dynamics.model:"},
        {[](auto& j) { j["plant"]["dynamics"]["model"]["series"][0]["den"][0] = 0; }, "plant.dynamics.model.series[0].den[0]"},
        {[](auto& j) { j["cases"][2]["controller"].erase("feedback"); }, "cases[2].controller.rc: repetitive control plugs into a feedback loop"},
        {[](auto& j) { j["cases"][1]["name"] = "pi"; }, "cases[1].name: duplicate case name"},
        {[](auto& j) { j["experiments"][0]["cases"][1] = "nope"; }, "experiments[0].cases[1]: no case named \"nope\""},
        {[](auto& j) { j["cases"][0]["controller"]["feedback"]["kind"] = "lqr"; }, "cases[0].controller.feedback.kind: must be one of none|pid|lti"},
        {[](auto& j) { j["plant"]["hysteresis"]["count"] = 17; }, "plant.hysteresis.count: must be an integer in [1, 16]"},
    };
    for (const Bad& b : bad) {
        nlohmann::json j = shan;
        b.edit(j);
        const std::string e = error_of(j);
        EXPECT_NE(e.find(b.expect), std::string::npos) << "got: " << e << "\nwanted: " << b.expect;
    }
    // Core validation with an index: thresholds not ascending.
    nlohmann::json j = read("janaideh2016");
    j["plant"]["hysteresis"]["thresholds_V"][3] = 0.5;
    EXPECT_NE(error_of(j).find("plant.hysteresis.thresholds[2]: must be strictly ascending"), std::string::npos)
        << error_of(j);
    // Dahl feedforward runs in the Q31 core too.
    j = read("ahmad2020");
    j["cases"][1]["sample"] = "q31";
    EXPECT_EQ(error_of(j), "");
    // The shipped files are valid.
    EXPECT_EQ(error_of(shan), "");
}

// WindowMetrics (streamed) against tracking_metrics / hysteresis_pct
// (stored) on the same samples: same definitions, so equal to rounding of
// the sums (1e-12 relative).
// controller.prefilter: a continuous model discretised by Tustin at the loop
// rate into the core's pre-filter sections (float and Q31), r shaped as they
// say; more than two sections are refused naming the field.
// A compensator given directly (commissioning writes one with its model's
// offset and, with strong hysteresis, in series): its offset and placement
// are read, and bad ones refused naming the field.
TEST(SimScenario, PiCompensatorOffsetAndPlacement) {
    nlohmann::json j = read("ahmad2020");
    j["cases"][0]["controller"]["feedforward"] = {{"kind", "pi_compensator"}, {"thresholds_um", {1.0}},
                                                  {"weights_V_per_um", {0.1}}, {"p0_V_per_um", 0.5},
                                                  {"input_offset_um", -0.25}, {"placement", "feedforward"}};
    const Scenario s = parse_scenario(j, kConfigs);
    EXPECT_EQ(s.cases[0].feedforward.pi.input_offset, -0.25f);
    EXPECT_EQ(s.cases[0].feedforward.placement, "feedforward");
    for (const auto& [field, value] : {std::pair<const char*, nlohmann::json>{"input_offset_um", 1e5},
                                       {"input_offset_um", "x"}, {"placement", "sideways"}}) {
        nlohmann::json bad = j;
        bad["cases"][0]["controller"]["feedforward"][field] = value;
        EXPECT_NE(error_of(bad).find(std::string("cases[0].controller.feedforward.") + field), std::string::npos)
            << field << ": " << error_of(bad);
    }
}

TEST(SimScenario, ReferencePreFilterBuildsIntoTheCoreSections) {
    nlohmann::json j = read("ahmad2020");
    // A notch at 1 kHz (ζ 0.01 -> 0.7): four poles, two sections.
    const double w = 2.0 * std::numbers::pi * 1000.0;
    auto pair = [&](double zeta) { return nlohmann::json{-zeta * w, w * std::sqrt(1.0 - zeta * zeta)}; };
    auto conj = [&](double zeta) { return nlohmann::json{-zeta * w, -w * std::sqrt(1.0 - zeta * zeta)}; };
    j["cases"][0]["controller"]["prefilter"] = {{"zeros", {pair(0.01), conj(0.01)}}, {"poles", {pair(0.7), conj(0.7)}},
                                                {"gain", 1.0}};
    const Scenario s = parse_scenario(j, kConfigs);
    for (const SampleType sample : {SampleType::kFloat, SampleType::kQ31}) {
        CaseSpec c = s.cases[0];
        c.sample = sample;
        BuildOptions o;
        o.check_realisation = false;
        const BuiltCase b = build_case(s, c, o);
        ASSERT_EQ(b.model.params.prefilter_count, 1);
        // Unit DC gain, and the section's zeros on the notch.
        const SosSection& f = b.model.params.prefilter[0];
        EXPECT_NEAR((f.b0 + f.b1 + f.b2) / (1.0 + f.a1 + f.a2), 1.0, 1e-9);
    }
    j["cases"][0]["controller"]["prefilter"]["zeros"] = {pair(0.01), conj(0.01), pair(0.02), conj(0.02), pair(0.03), conj(0.03)};
    j["cases"][0]["controller"]["prefilter"]["poles"] = {pair(0.7), conj(0.7), pair(0.6), conj(0.6), pair(0.5), conj(0.5)};
    const Scenario too_many = parse_scenario(j, kConfigs);
    try {
        (void)build_case(too_many, too_many.cases[0], BuildOptions{});
        FAIL() << "three sections";
    } catch (const std::exception& e) {
        EXPECT_NE(std::string(e.what()).find("cases[0].controller.prefilter"), std::string::npos) << e.what();
    }
    // An unstable model: the core refuses its realised section, named as
    // the feedforward group (and this controller) holds pre-filter sections.
    j["cases"][0]["controller"]["prefilter"] = {{"zeros", nlohmann::json::array()},
                                                {"poles", {{100.0, 0.0}, {-2000.0, 0.0}}}, {"gain", -200000.0}};
    const Scenario unstable = parse_scenario(j, kConfigs);
    for (const SampleType sample : {SampleType::kFloat, SampleType::kQ31}) {
        CaseSpec c = unstable.cases[0];
        c.sample = sample;
        try {
            (void)build_case(unstable, c, BuildOptions{});
            FAIL() << "a pole in the right half-plane";
        } catch (const std::exception& e) {
            EXPECT_NE(std::string(e.what()).find("cases[0].controller.prefilter[0].a1: poles must be inside the unit circle"),
                      std::string::npos) << e.what();
        }
    }
}

TEST(SimScenario, StreamedMetricsEqualStoredOnes) {
    std::mt19937 rng(4);
    std::normal_distribution<double> noise(0.0, 0.05);
    for (int trial = 0; trial < 20; ++trial) {
        const int n = 500 + trial * 37;
        const double phase = 0.3 * trial, lag = 0.05 * trial;
        std::vector<double> r, y;
        for (int k = 0; k < n; ++k) {
            const double t = 2.0 * M_PI * (k + 0.5) / n;
            r.push_back(3.0 + 2.0 * std::sin(t + phase));
            y.push_back(3.0 + 1.9 * std::sin(t + phase - lag) + noise(rng));
        }
        const auto [lo, hi] = std::minmax_element(r.begin(), r.end());
        WindowMetrics w(0.5 * (*lo + *hi));
        for (int k = 0; k < n; ++k) w.add(r[static_cast<size_t>(k)], y[static_cast<size_t>(k)]);
        const TrackingMetrics a = w.tracking(), b = tracking_metrics(r, y);
        EXPECT_NEAR(a.e_max_um, b.e_max_um, 1e-12);
        EXPECT_NEAR(a.e_pp_um, b.e_pp_um, 1e-12);
        EXPECT_NEAR(a.e_rms_um, b.e_rms_um, 1e-12 * b.e_rms_um);
        EXPECT_NEAR(a.e_max_pct, b.e_max_pct, 1e-10);
        EXPECT_NEAR(w.hysteresis_pct(), hysteresis_pct(r, y), 1e-10) << trial;
    }
}

// Double stage, no hysteresis, unit gains, ideal converters: a step through
// the amplifier's first-order lag alone must read, at the end of tick k, the
// exact lag response sampled at the last sub-step's midpoint (the value the
// hysteresis holds over that sub-step): 1 - e^{-w ((k+1) Ts - h/2)}. Float
// output: 1e-6.
TEST(SimScenario, DoubleStageAmplifierLagIsExact) {
    DoubleStageConfig c;
    c.rate_Hz = 100000.0;
    c.substeps = 8;
    c.amplifier.bandwidth_Hz = 3000.0f;
    DoubleStage st;
    st.configure(c);
    const double w = 2.0 * M_PI * 3000.0, ts = 1e-5, h = ts / 8;
    for (int k = 0; k < 50; ++k) {
        const double y = st.step(1.0f);
        EXPECT_NEAR(y, 1.0 - std::exp(-w * ((k + 1) * ts - h / 2)), 1e-6) << k;
    }
}

// A continuous resonance w^2/(s^2 + 2 zeta w s + w^2) after a static gain:
// with a held step the ZOH sub-steps are exact, so the reading at the end of
// tick k is the analytic step response at t = (k+1) Ts, whatever the number
// of sub-steps; float output: 1e-6.
TEST(SimScenario, DoubleStageDynamicsMatchTheAnalyticStepResponse) {
    const double f0 = 18e3, zeta = 0.1, w0 = 2.0 * M_PI * f0;
    design::Zpk z;
    const double wd = w0 * std::sqrt(1 - zeta * zeta);
    z.poles = {{-zeta * w0, wd}, {-zeta * w0, -wd}};
    z.gain = w0 * w0;
    for (const int sub : {1, 5}) {
        DoubleStageConfig c;
        c.substeps = sub;
        c.linear_gain_um_per_V = 2.0;
        c.dynamics = design::balance(design::zpk2ss(z));
        DoubleStage st;
        st.configure(c);
        for (int k = 0; k < 40; ++k) {
            const double t = (k + 1) * 1e-5;
            const double a = 1.0 - std::exp(-zeta * w0 * t) * (std::cos(wd * t) + zeta * w0 / wd * std::sin(wd * t));
            EXPECT_NEAR(st.step(0.5f), a, 1e-6) << "substeps " << sub << " tick " << k;
        }
    }
}

// The same chain in both fidelities with no continuous part (static PI
// hysteresis, 16-bit converters): identical up to float vs double rounding of
// the 15-operator sum (a few 1e-6 um), far below one ADC step.
TEST(SimScenario, StaticStageIsTheSameInBothFidelities) {
    StageConfig f{};
    f.dac = ConverterConfig{16, -10.0f, 10.0f};
    f.adc = ConverterConfig{16, -60.0f, 60.0f};
    f.plant.hysteresis = HysteresisKind::kPi;
    f.plant.pi = reference::true_stage_model();
    DoubleStageConfig d;
    d.dac = f.dac;
    d.adc = f.adc;
    d.hysteresis = HysteresisKind::kPi;
    d.pi = f.plant.pi;
    StageModel a;
    ASSERT_TRUE(a.configure(f).ok());
    DoubleStage b;
    b.configure(d);
    std::mt19937 rng(9);
    std::uniform_real_distribution<float> u(-10.0f, 10.0f);
    const float lsb = 120.0f / 65535.0f;
    int differ = 0;
    for (int k = 0; k < 5000; ++k) {
        const float v = u(rng);
        const float ya = a.step(v), yb = b.step(v);
        EXPECT_LE(std::fabs(ya - yb), lsb * 1.01f) << k;
        differ += ya != yb;
    }
    // Only where the two sums round to different sides of an ADC step.
    EXPECT_LT(differ, 50);
}

namespace {

// stiff_stack.json with every real-stage effect given.
nlohmann::json with_real_stage_effects() {
    nlohmann::json j = nlohmann::json::parse(std::ifstream(kConfigs + "stages/stiff_stack.json"));
    j["plant"]["sensor"]["offset_um"] = 0.3;
    j["plant"]["sensor"]["gain_error"] = 0.01;
    j["plant"]["sensor"]["mains"] = {{"frequency_Hz", 50}, {"amplitudes_um", {0.004, 0.002, 0.001}}};
    j["plant"]["creep"] = {{"percent_per_decade", 2}, {"from_s", 0.01}, {"to_s", 100}};
    j["plant"]["drift_um_per_s"] = 0.05;
    return j;
}

}  // namespace

// plant.sensor.offset_um, gain_error, mains; plant.creep, drift_um_per_s:
// read into the stage of both fidelities; without them the stage is the
// defaults (docs/models.md, configs/scenarios.md).
TEST(SimScenario, RealStageEffectsAreReadIntoTheStage) {
    const Scenario s = parse_scenario(with_real_stage_effects(), kConfigs + "stages");
    LoopModel m;
    build_stage(s, nullptr, 10, m);
    const SensorConfig& sf = m.stage.sensor;
    EXPECT_EQ(sf.offset_um, 0.3f);
    EXPECT_EQ(sf.gain_error, 0.01f);
    EXPECT_EQ(sf.mains.frequency_Hz, 50.0f);
    ASSERT_EQ(sf.mains.count, 3);
    EXPECT_EQ(sf.mains.amplitudes_um[2], 0.001f);
    EXPECT_EQ(m.stage.plant.creep, (CreepConfig{2.0f, 0.01f, 100.0f}));
    EXPECT_EQ(m.stage.plant.drift_um_per_s, 0.05f);
    EXPECT_EQ(m.stage_double.sensor.mains, sf.mains);
    EXPECT_EQ(m.stage_double.creep, m.stage.plant.creep);
    EXPECT_EQ(m.stage_double.drift_um_per_s, static_cast<double>(0.05f));
    StageModel stage;
    EXPECT_TRUE(stage.configure(m.stage).ok());

    const Scenario plain = load_scenario(kConfigs + "stages/stiff_stack.json");
    LoopModel p;
    build_stage(plain, nullptr, 10, p);
    EXPECT_EQ(p.stage.sensor.offset_um, 0.0f);
    EXPECT_EQ(p.stage.sensor.gain_error, 0.0f);
    EXPECT_EQ(p.stage.sensor.mains.count, 0);
    EXPECT_EQ(p.stage.plant.creep.percent_per_decade, 0.0f);
    EXPECT_EQ(p.stage.plant.drift_um_per_s, 0.0f);
}

TEST(SimScenario, RealStageEffectsRefuseBadValuesNamingTheField) {
    struct Bad {
        std::function<void(nlohmann::json&)> edit;
        std::string expect;
    };
    const Bad bad[] = {
        {[](auto& j) { j["plant"]["sensor"]["mains"]["amplitudes_um"][1] = -0.001; },
         "plant.sensor.mains.amplitudes_um[1]: must be finite and in [0, 1000] um"},
        {[](auto& j) { j["plant"]["sensor"]["mains"]["amplitudes_um"] = nlohmann::json::array(); },
         "plant.sensor.mains.amplitudes_um: must hold 1 to 8 amplitudes"},
        {[](auto& j) { j["plant"]["sensor"]["mains"]["frequency_Hz"] = 0; },
         "plant.sensor.mains.frequency_Hz: must be in [1, 1000]"},
        {[](auto& j) { j["loop"]["rate_Hz"] = 12500; j["plant"]["sensor"]["mains"]["frequency_Hz"] = 1000; j["plant"]["sensor"]["mains"]["amplitudes_um"] = {1, 1, 1, 1, 1, 1, 1, 1}; },
         "plant.sensor.mains.amplitudes_um: every harmonic must lie below rate / 2"},
        {[](auto& j) { j["plant"]["sensor"]["mains"]["phase"] = 1; }, "plant.sensor.mains.phase: unknown field"},
        {[](auto& j) { j["plant"]["sensor"]["offset_um"] = 5000; }, "plant.sensor.offset_um: must be in [-1000, 1000]"},
        {[](auto& j) { j["plant"]["sensor"]["gain_error"] = -0.7; }, "plant.sensor.gain_error: must be in [-0.5, 0.5]"},
        {[](auto& j) { j["plant"]["creep"]["to_s"] = 50; }, "plant.creep.to_s: must be from_s * 10^K, K = 1..8"},
        {[](auto& j) { j["plant"]["creep"]["percent_per_decade"] = 30; }, "plant.creep.percent_per_decade: must be in [0, 20]"},
        {[](auto& j) { j["plant"]["creep"]["from_s"] = 0; }, "plant.creep.from_s: must be in [0.0001, 10000]"},
        {[](auto& j) { j["plant"]["creep"]["from_s"] = 0.0001; j["plant"]["creep"]["to_s"] = 0.001; },
         "plant.creep.from_s: must be at least 2 samples (2 / rate)"},
        {[](auto& j) { j["plant"]["creep"].erase("to_s"); }, "plant.creep.to_s: required field is missing"},
        {[](auto& j) { j["plant"]["drift_um_per_s"] = 11; }, "plant.drift_um_per_s: must be in [-10, 10]"},
        // Stage poles that do not settle, or sit at s = 0 at the loop rate's
        // resolution (which the discretisation once met as an internal
        // pairing error or a float section on the unit circle).
        {[](auto& j) { j["plant"]["dynamics"]["model"]["poles"].push_back({-1e-300, 0}); },
         "plant.dynamics.model: pole -1e-300 + 0j rad/s is at s = 0"},
        {[](auto& j) { j["plant"]["dynamics"]["model"]["poles"].push_back({-3e-14, 0}); }, "is at s = 0"},
        {[](auto& j) { j["plant"]["dynamics"]["model"]["poles"].push_back({0.7, 0}); },
         "plant.dynamics.model: pole 0.7 + 0j rad/s is not in the left half-plane"},
        {[](auto& j) {
             j["plant"]["dynamics"]["model"]["poles"].push_back({0.0, 900.0});
             j["plant"]["dynamics"]["model"]["poles"].push_back({0.0, -900.0});
         },
         "pole 0 + 900j rad/s is not in the left half-plane"},
    };
    for (const Bad& b : bad) {
        nlohmann::json j = with_real_stage_effects();
        b.edit(j);
        const std::string e = error_of(j);
        EXPECT_NE(e.find(b.expect), std::string::npos) << "got: " << e << "\nwanted: " << b.expect;
    }
    EXPECT_EQ(error_of(with_real_stage_effects()), "");
}

// The double fidelity carries the same effects: with no continuous part
// and a static linear stage, its reading is the float stage's to float
// rounding (the creep: continuous lags against the float bank's held ones,
// at most 1 % of each lag's weight apart, test_creep.cpp).
TEST(SimScenario, RealStageEffectsAreTheSameInBothFidelities) {
    StageConfig f{};
    f.rate_Hz = 20000.0f;
    f.plant.linear_gain_um_per_V = 1.5f;
    f.plant.creep = {2.0f, 0.001f, 0.1f};
    f.plant.drift_um_per_s = 0.05f;
    f.sensor = {0.4f, 0.0f, 0.0f, 1};
    f.sensor.offset_um = 0.3f;
    f.sensor.gain_error = 0.01f;
    f.sensor.mains.count = 3;
    f.sensor.mains.amplitudes_um = {0.004f, 0.002f, 0.001f};
    DoubleStageConfig d;
    d.rate_Hz = 20000.0;
    d.substeps = 1;
    d.linear_gain_um_per_V = 1.5;
    d.creep = f.plant.creep;
    d.drift_um_per_s = 0.05f;
    d.sensor = f.sensor;
    StageModel a;
    ASSERT_TRUE(a.configure(f).ok());
    DoubleStage b;
    b.configure(d);
    double worst = 0.0;
    for (int k = 0; k < 40000; ++k) {
        const float y_a = a.step(6.0f), y_b = b.step(6.0f);
        worst = std::max(worst, std::fabs(static_cast<double>(y_a) - y_b));
    }
    // Creep of a 9 µm step: 1 % of (p/100) sum w = 0.02 * 3.18 * 9 µm * 0.01
    // = 5.7e-3 µm at most, times the sensor gain 0.404: 2.3e-3.
    EXPECT_LT(worst, 2.3e-3);
    // After 2 s (20 of the slowest lag's tau) the lags have settled: the two
    // agree to float rounding of the reading (a few ulp of 4), drift and
    // mains included.
    for (int k = 0; k < 2000; ++k) {
        const float y_a = a.step(6.0f), y_b = b.step(6.0f);
        EXPECT_NEAR(y_a, y_b, 2e-6) << k;
    }
}

// The made-up stages of configs/stages/ load, their one case builds, and
// their stage fits an emulated board's profile; the three with real-stage
// effects carry what their README says.
TEST(SimScenario, MadeUpStagesLoadAndFitTheEmulatedBoards) {
    for (const char* name : {"stiff_stack", "soft_bender", "rhp_zero", "stiff_stack_unipolar", "drifting_stage",
                             "strong_hysteresis", "asymmetric_hysteresis"}) {
        SCOPED_TRACE(name);
        const Scenario s = load_scenario(kConfigs + "stages/" + name + ".json");
        ASSERT_EQ(s.cases.size(), 1u);
        BuildOptions o;
        o.reference_frequency_Hz = 10.0;
        o.check_realisation = false;
        EXPECT_NO_THROW(build_case(s, s.find_case("open_loop"), o));
        LoopModel m;
        build_stage(s, nullptr, 10, m);
        EmulationProfile p;
        p.loop_rate_Hz = static_cast<uint32_t>(s.rate_Hz);
        p.position_full_scale_um = s.setup.position.full_scale;
        p.voltage_full_scale_V = s.setup.voltage.full_scale;
        p.stage = m.stage;
        EXPECT_TRUE(validate(p).ok()) << describe(validate(p));
    }
    const Scenario u = load_scenario(kConfigs + "stages/stiff_stack_unipolar.json");
    EXPECT_EQ(u.limits.u_min_V, 0.0f);
    EXPECT_EQ(u.limits.u_max_V, 10.0f);
    EXPECT_EQ(u.plant.amplifier.input_min_V, -1.0f);
    EXPECT_EQ(u.plant.amplifier.input_max_V, 11.0f);
    EXPECT_EQ(u.plant.adc.min, 0.0f);
    EXPECT_EQ(u.plant.sensor.gain, 0.4f);
    const Scenario d = load_scenario(kConfigs + "stages/drifting_stage.json");
    EXPECT_EQ(d.plant.creep, (CreepConfig{2.0f, 0.01f, 100.0f}));
    EXPECT_EQ(d.plant.sensor.mains.count, 3);
    EXPECT_NE(d.plant.drift_um_per_s, 0.0f);
    EXPECT_NE(d.plant.sensor.offset_um, 0.0f);
    EXPECT_NE(d.plant.sensor.gain_error, 0.0f);
    // Strong hysteresis: the loading slope about mid-span (75 V) is 4 times
    // the slope after a reversal (p0).
    const Scenario h = load_scenario(kConfigs + "stages/strong_hysteresis.json");
    const PiModel& pi = h.plant.hysteresis.pi;
    double slope = pi.p0;
    for (int j = 0; j < pi.count; ++j)
        if (pi.thresholds[static_cast<size_t>(j)] < 75.0f) slope += pi.weights[static_cast<size_t>(j)];
    EXPECT_NEAR(slope / pi.p0, 4.0, 0.01);
    // The asymmetric loop: S's slope 1, 0.75 above 8 um, 0.5 above 16 um,
    // carried to the float stage.
    const Scenario a = load_scenario(kConfigs + "stages/asymmetric_hysteresis.json");
    const OutputMap& om = a.plant.hysteresis.output_map;
    ASSERT_EQ(om.count, 2);
    EXPECT_EQ(om.thresholds_um[1], 16.0f);
    EXPECT_EQ(1.0f + om.weights[0] + om.weights[1], 0.5f);
    LoopModel am;
    build_stage(a, nullptr, 10, am);
    EXPECT_EQ(am.stage.plant.output_map.weights, om.weights);
    EXPECT_EQ(am.stage_double.output_map.thresholds_um, om.thresholds_um);
}

// A pi hysteresis's output map: refused naming its entry, as the file has it.
TEST(SimScenario, OutputMapRefusalsNameTheEntry) {
    const auto refused = [](const std::string& map) {
        const std::string text = R"({"scenario": "t", "title": "t", "source": "t",
          "loop": {"rate_Hz": 10000, "position_full_scale_um": 50, "voltage_full_scale_V": 12,
                   "hard_limits": {"u_min_V": -10, "u_max_V": 10, "slew_V_per_s": 1e6}},
          "plant": {"dac": {"bits": 0, "min": -10, "max": 10},
                    "amplifier": {"gain": 1, "input_min_V": -10, "input_max_V": 10, "output_min_V": -10, "output_max_V": 10},
                    "hysteresis": {"kind": "pi", "thresholds_V": [1, 2], "weights_um_per_V": [0.2, 0.1], "p0_um_per_V": 1,
                                   "output_map": )" + map + R"(},
                    "sensor": {"gain_per_um": 1, "noise_rms": 0, "seed": 1}, "adc": {"bits": 0, "min": -50, "max": 50}},
          "reference": {"nominal_um_per_V": 1, "offset": "bipolar"},
          "cases": [{"name": "open_loop", "label": "open loop", "controller": {"feedforward": {"kind": "gain", "V_per_um": 1}}}]})";
        try {
            (void)parse_scenario(nlohmann::json::parse(text), ".");
        } catch (const ScenarioError& e) {
            return std::string(e.what());
        }
        return std::string("accepted");
    };
    EXPECT_EQ(refused(R"({"thresholds_um": [1, 2], "weights": [-0.2, -0.3]})"), "accepted");
    EXPECT_NE(refused(R"({"thresholds_um": [1, 2], "weights": [-0.2, -0.9]})").find("plant.hysteresis.output_map.weights[1]"),
              std::string::npos);
    EXPECT_NE(refused(R"({"thresholds_um": [2, 1], "weights": [-0.2, -0.3]})").find("plant.hysteresis.output_map.thresholds_um[1]"),
              std::string::npos);
    EXPECT_NE(refused(R"({"thresholds_um": [1, 2], "weights": [-0.2]})").find("plant.hysteresis.output_map.weights"),
              std::string::npos);
    EXPECT_NE(refused(R"({"thresholds_um": [], "weights": []})").find("plant.hysteresis.output_map.thresholds_um"),
              std::string::npos);
    EXPECT_NE(refused(R"({"thresholds_um": [1], "weights": [0.1], "x": 1})").find("x"), std::string::npos);
}
