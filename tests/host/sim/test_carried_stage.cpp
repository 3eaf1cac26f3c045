// The rest a carried stage gets between runs, against its closed form: on a
// stage that reads its command (static gain 1, no dynamics, ideal
// converters), the reading after the rest is the safe command, reached by a
// ramp of slew / rate per tick, and a stage that has not run is left alone.
#include "sim/carried_stage.hpp"

#include <gtest/gtest.h>

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

}  // namespace
}  // namespace piezoloop::sim
