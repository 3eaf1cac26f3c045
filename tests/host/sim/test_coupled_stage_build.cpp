// Scenarios of coupled axes (plant.axes, plant.coupling; configs/scenarios.md)
// and the core stage built from them (sim/coupled_stage_build.hpp): the
// shipped XY and XYZ flexures load; the float stage's step responses against
// scipy's (tools/ref/coupled_stage_ref.py); a single-axis scenario gives the
// simulator's stage bit for bit; bad files are refused naming the field; the
// single-axis simulator refuses a multi-axis scenario.
#include <gtest/gtest.h>

#include <bit>
#include <cmath>
#include <string>

#include "coupled_stage_fixture.hpp"
#include "sim/build_case.hpp"
#include "sim/coupled_stage_build.hpp"
#include "test_support.hpp"

using namespace piezoloop;
using namespace piezoloop::sim;

namespace {

std::string parse_error(const nlohmann::json& j) {
    try {
        (void)parse_scenario(j, test::configs_dir() + "stages");
    } catch (const ScenarioError& e) {
        return e.what();
    }
    return "";
}

double dc_gain(const std::vector<SosSection>& sos) {
    double g = 1.0;
    for (const SosSection& s : sos) g *= (s.b0 + s.b1 + s.b2) / (1.0 + s.a1 + s.a2);
    return g;
}

}  // namespace

TEST(CoupledStageBuild, ShippedFlexuresLoadAndBuild) {
    const Scenario xyz = load_scenario(test::configs_dir() + "stages/xyz_flexure.json");
    ASSERT_TRUE(xyz.multi_axis());
    ASSERT_EQ(xyz.axes.size(), 3u);
    EXPECT_EQ(xyz.axes[2].name, "z");
    EXPECT_EQ(xyz.axes[2].path, "plant.axes[2]");
    ASSERT_EQ(xyz.coupling.size(), 4u);
    EXPECT_EQ(xyz.coupling[3].from, "y");
    EXPECT_EQ(xyz.coupling[3].to_axis, 2);
    EXPECT_EQ(xyz.cases.size(), 3u);  // open_loop, pi_notch, pi_notch_decoupled
    const CoupledStageConfig c = coupled_stage_config(xyz);
    EXPECT_EQ(c.axes, 3);
    EXPECT_EQ(c.paths, 4);
    EXPECT_EQ(c.axis[0].plant.hysteresis, HysteresisKind::kPi);
    EXPECT_EQ(c.axis[2].plant.sections, 1);
    for (size_t k = 0; k < xyz.coupling.size(); ++k) {
        // One section each, its DC gain the path's, and 10 % (-20 dB) at the
        // source's first mode (the damping is chosen so).
        EXPECT_EQ(c.coupling[k].sections, 1);
        const std::vector<SosSection> sos(c.coupling[k].filter.begin(), c.coupling[k].filter.begin() + 1);
        EXPECT_NEAR(dc_gain(sos), xyz.coupling[k].dc_gain, 1e-12);
        EXPECT_NEAR(xyz.coupling[k].dc_gain / (2.0 * xyz.coupling[k].damping), 0.1, 1e-9);
    }
    const Scenario xy = load_scenario(test::configs_dir() + "stages/xy_flexure.json");
    ASSERT_EQ(xy.axes.size(), 2u);
    EXPECT_EQ(coupled_stage_config(xy).paths, 2);
    // The XY flexure is the XYZ's without Z.
    EXPECT_EQ(test::stage_json("xy_flexure")["plant"]["axes"][1], test::stage_json("xyz_flexure")["plant"]["axes"][1]);
    // A full-stage run: a 5 V command on x alone moves y by about 3 % of x at
    // rest (hysteresis, converters and noise on).
    CoupledStage stage;
    ASSERT_TRUE(stage.configure(c).ok());
    const float u[3] = {5.0f, 0.0f, 0.0f};
    float y[3];
    for (int k = 0; k < 4000; ++k) stage.step(u, y);
    EXPECT_NEAR(stage.position_um(1) / stage.position_um(0), 0.03, 1e-3);
    EXPECT_NEAR(y[1] / c.axis[1].sensor.gain / stage.position_um(1), 1.0, 0.01);
}

// The float stage after a 1 V step on each input in turn, every reading /
// sensor gain, against scipy's dlsim of the same blocks in double (2000
// samples, 0.1 s). Differences come from float: the coefficients' rounding
// (relative 2^-24) moves the lightly damped poles (r = 0.994 at 750 Hz) and
// the states carry rounding through the slow decay, about 1e-7 relative
// per operation times the ringing's ~1 / (1 - r) = 170 samples of memory.
// Measured: at most 5.1e-6 of the largest response (the x axis, 19.6 um at
// its peak); the bound, 2e-5 of that peak (0.4 nm) on every output, is 4
// times that.
TEST(CoupledStageBuild, StepResponsesEqualScipy) {
    const nlohmann::json ref = test::load_golden("coupled_stage_ref");
    const Scenario s = test::linear_xyz_flexure(ref);
    const CoupledStageConfig c = coupled_stage_config(s);
    const int n = ref["step_samples"].get<int>();
    const double step_V = ref["step_V"].get<double>();
    double peak = 0.0;
    for (const auto& input : ref["steps"])
        for (const auto& out : input)
            for (const auto& v : out) peak = std::max(peak, std::fabs(v.get<double>()));
    ASSERT_GT(peak, 10.0);
    double worst = 0.0;
    for (int j = 0; j < 3; ++j) {
        CoupledStage stage;
        ASSERT_TRUE(stage.configure(c).ok());
        float u[3] = {0.0f, 0.0f, 0.0f};
        u[j] = static_cast<float>(step_V);
        for (int k = 0; k < n; ++k) {
            float y[3];
            stage.step(u, y);
            for (int i = 0; i < 3; ++i) {
                const double got = static_cast<double>(y[i]) / static_cast<double>(c.axis[static_cast<size_t>(i)].sensor.gain);
                const double want = ref["steps"][j][i][k].get<double>();
                worst = std::max(worst, std::fabs(got - want));
                ASSERT_NEAR(got, want, 2e-5 * peak) << "input " << j << " output " << i << " sample " << k;
            }
        }
    }
    std::printf("worst step error: %.3g of the peak %.4g um\n", worst / peak, peak);
}

// A single-axis scenario as a CoupledStage is the simulator's StageModel.
TEST(CoupledStageBuild, SingleAxisScenarioIsTheSimulatorsStageBitForBit) {
    for (const char* name : {"stiff_stack", "drifting_stage", "asymmetric_hysteresis"}) {
        SCOPED_TRACE(name);
        const Scenario s = load_scenario(test::configs_dir() + "stages/" + name + ".json");
        LoopModel m;
        build_stage(s, nullptr, 10, m);
        StageModel reference;
        ASSERT_TRUE(reference.configure(m.stage).ok());
        CoupledStage stage;
        ASSERT_TRUE(stage.configure(coupled_stage_config(s)).ok());
        ASSERT_EQ(stage.axes(), 1);
        for (int k = 0; k < 20000; ++k) {
            const float u = static_cast<float>(5.0 + 4.0 * std::sin(2.0 * M_PI * 13.0 * k / s.rate_Hz));
            float y = 0.0f;
            stage.step(&u, &y);
            ASSERT_EQ(std::bit_cast<uint32_t>(y), std::bit_cast<uint32_t>(reference.step(u))) << k;
        }
    }
    // One entry in plant.axes is a single-axis plant.
    nlohmann::json j = test::stage_json("xyz_flexure");
    j["plant"]["axes"] = nlohmann::json::array({j["plant"]["axes"][0]});
    j["plant"].erase("coupling");
    j["cases"] = nlohmann::json::array({j["cases"][0]});  // the others name axes y and z
    const Scenario one = parse_scenario(j, test::configs_dir() + "stages");
    EXPECT_FALSE(one.multi_axis());
    EXPECT_EQ(one.plant.amplifier.gain, 15.0f);
    LoopModel m;
    EXPECT_NO_THROW(build_stage(one, nullptr, 10, m));
}

TEST(CoupledStageBuild, BadFilesAreRefusedNamingTheField) {
    const nlohmann::json good = test::stage_json("xyz_flexure");
    EXPECT_EQ(parse_error(good), "");
    nlohmann::json j = good;
    j["plant"]["coupling"][0]["from"] = "w";
    EXPECT_EQ(parse_error(j), "plant.coupling[0].from: must be one of the axis names x, y, z (got \"w\")");
    j = good;
    j["plant"]["coupling"][1]["to"] = "y";  // y -> y
    EXPECT_EQ(parse_error(j), "plant.coupling[1].to: must differ from `from` (\"y\"): no path from an axis to itself");
    j = good;
    j["plant"]["coupling"][2]["from"] = "x";
    j["plant"]["coupling"][2]["to"] = "y";
    EXPECT_EQ(parse_error(j), "plant.coupling[2]: a path from x to y is given already (plant.coupling[0])");
    j = good;
    j["plant"]["axes"][2]["name"] = "x";
    EXPECT_EQ(parse_error(j), "plant.axes[2].name: duplicate axis name \"x\"");
    j = good;
    j["plant"]["axes"].push_back(good["plant"]["axes"][2]);
    j["plant"]["axes"][3]["name"] = "w";
    EXPECT_EQ(parse_error(j), "plant.axes: must hold 1 to 3 axes (got 4)");
    j = good;
    j["plant"]["axes"] = nlohmann::json::array();
    EXPECT_EQ(parse_error(j), "plant.axes: must hold 1 to 3 axes (got 0)");
    j = good;
    j["plant"]["coupling"][0]["mode_Hz"] = 10000.0;
    EXPECT_EQ(parse_error(j), "plant.coupling[0].mode_Hz: must be in (0, rate / 2)");
    j = good;
    j["plant"]["coupling"][0]["damping"] = 0.0;
    EXPECT_EQ(parse_error(j), "plant.coupling[0].damping: must be in [0.001, 10]");
    j = good;
    j["plant"]["coupling"][0]["dc_gain"] = 0.0;
    EXPECT_EQ(parse_error(j), "plant.coupling[0].dc_gain: must be non-zero (leave the path out for none)");
    j = good;
    j["plant"]["coupling"][0]["discretisation"] = "euler";
    EXPECT_NE(parse_error(j).find("plant.coupling[0].discretisation: "), std::string::npos);
    j = good;
    j["plant"]["axes"][1]["sensor"]["bandwidth_Hz"] = 10000.0;
    EXPECT_EQ(parse_error(j), "plant.axes[1].sensor.bandwidth_Hz: must be below rate / 2 (the float stage discretises it)");
    j = good;
    j["plant"]["axes"][1].erase("name");
    EXPECT_EQ(parse_error(j), "plant.axes[1].name: required field is missing");
    j = good;
    j["plant"]["dac"] = good["plant"]["axes"][0]["dac"];  // single-axis fields beside axes
    EXPECT_NE(parse_error(j).find("plant.dac: unknown field"), std::string::npos);
    j = good;
    j["plant"] = good["plant"]["axes"][0];
    j["plant"].erase("name");
    j["plant"]["coupling"] = good["plant"]["coupling"];
    EXPECT_EQ(parse_error(j), "plant.axes: required with plant.coupling: the axes the paths join");
}

TEST(CoupledStageBuild, TheSingleAxisSimulatorRefusesMultiAxisScenarios) {
    const Scenario s = load_scenario(test::configs_dir() + "stages/xy_flexure.json");
    EXPECT_EQ(test::error_of([&] { require_single_axis(s, "sim"); }),
              "multi-axis scenario: sim runs single-axis stages only so far (xy_flexure: plant.axes x, y)");
    LoopModel m;
    EXPECT_NE(test::error_of([&] { build_stage(s, nullptr, 10, m); })
                  .find("multi-axis scenario: this command runs single-axis stages only so far"),
              std::string::npos);
    const Scenario single = load_scenario(test::configs_dir() + "stages/stiff_stack.json");
    EXPECT_NO_THROW(require_single_axis(single, "sim"));
}
