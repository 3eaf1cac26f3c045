// The emulated samples' heights against their closed forms, the command
// line's sample specs and their refusals, and the virtual probe reading the
// coupled stage's true position.
#include <gtest/gtest.h>

#include <cmath>
#include <stdexcept>
#include <string>

#include "scan/sample_spec.hpp"
#include "scan/sample_surface.hpp"
#include "scan/virtual_probe.hpp"
#include "sim/coupled_stage_build.hpp"
#include "coupled_stage_fixture.hpp"

using namespace piezoloop;
using namespace piezoloop::scan;

TEST(SampleSurface, GratingIsRaisedOverDutyOfEachPeriod) {
    const SampleSurface g = parse_sample_spec("grating:pitch=2,height_nm=50,duty=0.25");
    EXPECT_EQ(g.height_at_nm(0.0, 3.0), 50.0);
    EXPECT_EQ(g.height_at_nm(0.49, -7.0), 50.0);
    EXPECT_EQ(g.height_at_nm(0.51, 0.0), 0.0);
    EXPECT_EQ(g.height_at_nm(1.99, 0.0), 0.0);
    EXPECT_EQ(g.height_at_nm(2.01, 0.0), 50.0);
    EXPECT_EQ(g.height_at_nm(-1.9, 0.0), 50.0);  // -1.9 = -2 + 0.1
    EXPECT_EQ(g.height_at_nm(-1.4, 0.0), 0.0);
    // The mean over a period is duty * height (a fine Riemann sum).
    double sum = 0.0;
    const int n = 100000;
    for (int i = 0; i < n; ++i) sum += g.height_at_nm(10.0 + 2.0 * (i + 0.5) / n, 1.0);
    EXPECT_NEAR(sum / n, 12.5, 1e-9);
}

TEST(SampleSurface, StepAndDots) {
    const SampleSurface s = parse_sample_spec("step:x=1.5,height_nm=30");
    EXPECT_EQ(s.height_at_nm(1.49, 0.0), 0.0);
    EXPECT_EQ(s.height_at_nm(1.5, 9.0), 30.0);
    const SampleSurface d = parse_sample_spec("dots:pitch=4,radius=1,height_nm=10");
    EXPECT_EQ(d.height_at_nm(8.0, -4.0), 10.0);          // a dot's centre
    EXPECT_EQ(d.height_at_nm(8.6, -3.3), 10.0);          // 0.6^2 + 0.7^2 = 0.85 < 1
    EXPECT_EQ(d.height_at_nm(8.8, -3.3), 0.0);           // 0.8^2 + 0.7^2 = 1.13 > 1
    EXPECT_EQ(d.height_at_nm(2.0, 2.0), 0.0);            // between four dots
    EXPECT_EQ(parse_sample_spec("dots").height_nm, 20.0);
}

TEST(SampleSpec, DescribeRoundTrips) {
    for (const char* spec : {"grating:pitch=3,height_nm=40,duty=0.3", "step:x=-2,height_nm=5",
                             "dots:pitch=2,radius=0.4,height_nm=7"}) {
        const SampleSurface s = parse_sample_spec(spec);
        EXPECT_EQ(s.describe(), spec);
    }
}

TEST(SampleSpec, RefusalsNameTheKey) {
    auto message = [](const std::string& spec) {
        try {
            (void)parse_sample_spec(spec);
        } catch (const std::invalid_argument& e) {
            return std::string(e.what());
        }
        return std::string("accepted");
    };
    EXPECT_NE(message("ruler:pitch=2").find("grating, step or dots"), std::string::npos);
    EXPECT_NE(message("grating:pitch=0").find("'pitch'"), std::string::npos);
    EXPECT_NE(message("grating:pitch=abc").find("'pitch'"), std::string::npos);
    EXPECT_NE(message("grating:duty=1").find("'duty'"), std::string::npos);
    EXPECT_NE(message("grating:radius=1").find("'radius' is not a key"), std::string::npos);
    EXPECT_NE(message("dots:pitch=2,radius=1").find("'radius'"), std::string::npos);
    EXPECT_NE(message("step:height_nm=-1").find("'height_nm'"), std::string::npos);
    EXPECT_NE(message("grating:pitch").find("key=value"), std::string::npos);
}

TEST(VirtualProbe, ReadsTheStagesTruePosition) {
    const sim::Scenario s = sim::load_scenario(test::configs_dir() + "stages/xy_flexure.json");
    CoupledStage stage;
    ASSERT_TRUE(stage.configure(sim::coupled_stage_config(s)).ok());
    const VirtualProbe probe(parse_sample_spec("grating:pitch=0.7,height_nm=50"));
    const float u[2] = {4.0f, 2.0f};
    float readings[2] = {};
    int raised = 0;
    for (int k = 0; k < 2000; ++k) {
        stage.step(u, readings);
        const double x = stage.position_um(0), y = stage.position_um(1);
        ASSERT_EQ(probe.read_nm(stage), probe.surface().height_at_nm(x, y));
        raised += probe.read_nm(stage) > 0.0;
    }
    EXPECT_GT(raised, 0);
    EXPECT_LT(raised, 2000);  // the stage moved across lines of the grating
}
