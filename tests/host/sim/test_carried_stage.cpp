// The rest a carried stage gets between runs, against its closed form: on a
// stage that reads its command (static gain 1, no dynamics, ideal
// converters), the reading after the rest is the safe command, reached by a
// ramp of slew / rate per tick, and a stage that has not run is left alone.
// A run that carries a stage on starts its wave's approach from the stage's
// reading, as a board's does, and takes the ticks planned for it.
#include "sim/carried_stage.hpp"

#include <gtest/gtest.h>

#include <nlohmann/json.hpp>

#include "sim/closed_loop.hpp"
#include "sim/experiments.hpp"
#include "sim/scenario.hpp"
#include "sim/sim_case.hpp"

namespace piezoloop::sim {
namespace {

CarriedStage unit_stage(float command_V) {
    CarriedStage c;
    StageConfig sc;
    sc.rate_Hz = 1000.0f;
    sc.plant.hysteresis = HysteresisKind::kNone;
    sc.plant.linear_gain_um_per_V = 1.0f;
    EXPECT_TRUE(c.stage.configure(sc).ok());
    c.command_V = command_V;
    c.reading_um = command_V;
    c.started = true;
    return c;
}

TEST(CarriedStage, RampsToTheSafeCommandAtTheSlewLimitThenHolds) {
    LimitsConfig lim;
    lim.u_min_V = -10.0f;
    lim.u_max_V = 10.0f;
    lim.slew_V_per_s = 1000.0f;  // 1 V per tick at 1 kHz
    CarriedStage c = unit_stage(7.5f);
    c.rest(lim, 1000.0f, 1.0f, 0.0);
    // 7.5 V down by 1 V a tick: the eighth tick lands on 0 V exactly.
    EXPECT_EQ(c.command_V, 0.0f);
    EXPECT_EQ(c.reading_um, 0.0f);
}

TEST(CarriedStage, TheSafeCommandIsZeroWithinTheLimits) {
    LimitsConfig lim;
    lim.u_min_V = 2.0f;  // a unipolar span that excludes 0 V: its lower end
    lim.u_max_V = 10.0f;
    lim.slew_V_per_s = 1e6f;
    CarriedStage c = unit_stage(9.0f);
    c.rest(lim, 1000.0f, 1.0f, 0.01);
    EXPECT_EQ(c.command_V, 2.0f);
    EXPECT_EQ(c.reading_um, 2.0f);
}

TEST(CarriedStage, AStageThatHasNotRunStaysAtRest) {
    LimitsConfig lim;
    lim.u_min_V = 2.0f;
    lim.u_max_V = 10.0f;
    lim.slew_V_per_s = 1e6f;
    CarriedStage c = unit_stage(9.0f);
    c.started = false;
    c.rest(lim, 1000.0f, 1.0f, 0.01);
    EXPECT_EQ(c.command_V, 9.0f);
    EXPECT_EQ(c.reading_um, 9.0f);
}

// An ideal linear stage (2 um/V, a sensor offset of 3 um, no dynamics)
// under a plain PI loop: at rest at 0 V it reads 3 um, not 0.
Scenario offset_stage() {
    const nlohmann::json j = {
        {"scenario", "carried"},
        {"loop", {{"rate_Hz", 10000}, {"position_full_scale_um", 64}, {"voltage_full_scale_V", 16},
                  {"hard_limits", {{"u_min_V", -10}, {"u_max_V", 10}, {"slew_V_per_s", 1e6}}}}},
        {"plant", {{"dac", {{"bits", 0}, {"min", -10}, {"max", 10}}},
                   {"amplifier", {{"gain", 1}, {"input_min_V", -10}, {"input_max_V", 10}, {"output_min_V", -10},
                                  {"output_max_V", 10}}},
                   {"hysteresis", {{"kind", "none"}, {"gain_um_per_V", 2}}},
                   {"sensor", {{"gain_per_um", 1}, {"offset_um", 3}}},
                   {"adc", {{"bits", 0}, {"min", -100}, {"max", 100}}}}},
        {"reference", {{"nominal_um_per_V", 2}, {"offset", "bipolar"}}},
        {"cases", {{{"name", "pi"}, {"controller", {{"feedback", {{"kind", "pid"}, {"kp", 0.1},
                                                                   {"ki_per_s", 500}, {"kd_s", 0},
                                                                   {"derivative_cutoff_Hz", 1000},
                                                                   {"u_min_V", -10}, {"u_max_V", 10}}}}}}}}};
    return parse_scenario(j, ".");
}

TEST(CarriedStage, ARunStartsItsApproachFromTheStagesReading) {
    const Scenario s = offset_stage();
    BuildOptions bo;
    bo.check_realisation = false;
    const BuiltCase b = build_case(s, s.cases.front(), bo);
    TrajectoryRequest t;
    t.waveform = Waveform::kTriangle;
    t.frequency_Hz = 20.0;
    t.range_um = 10.0;
    t.midpoint_um = 20.0;  // the triangle 15 .. 25 um, its first point 15 um
    RunOptions o = plan_run(s.rate_Hz, t, 0, false);
    o.log_start = 0;
    o.log_every = 1;
    CarriedStage carried;
    carried.stage = StageModel{};
    StageConfig sc = b.model.stage;
    sc.rate_Hz = static_cast<float>(s.rate_Hz);
    ASSERT_TRUE(carried.stage.configure(sc).ok());
    carried.reading_um = 3.0f;  // the stage at rest: 0 V, its sensor's offset
    carried.started = true;
    o.carried = &carried;
    make_room_for_approach(b.model, o, carried.reading_um);
    const RunResult r = run_loop(b.model, o);
    ASSERT_GT(o.approach_ticks, 10u);
    // The approach leaves the reading with no jump of the reference: its
    // first sample is the reading, within the minimum-jerk profile's first
    // step (zero slope there).
    EXPECT_NEAR(r.log.y_um.front(), 3.0f, 1e-6f);
    EXPECT_NEAR(r.log.r_um.front(), 3.0f, 1e-3f);
    // The wave's first point (15 um) is reached exactly where the plan put
    // it, so the measured window is the triangle's own.
    EXPECT_FLOAT_EQ(r.log.r_um[o.approach_ticks], 15.0f);
    EXPECT_LT(r.log.r_um[o.approach_ticks - 1], 15.0f);
}

}  // namespace
}  // namespace piezoloop::sim
