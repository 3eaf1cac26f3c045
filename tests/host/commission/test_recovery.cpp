// Recovery after saturation (commission/recovery.hpp) of every loop the
// commissioning makes on the shipped stages: commissioned on the simulator
// here, then driven beyond its range above and below for 0.2 s each, on the
// identified stage (DIR/scenario.json) and on the true stage, in float and
// in Q31. Each must come back within 0.1 % of the range of the centre, and
// no later than 5 periods of its closed-loop bandwidth (5 / f_bw) after it
// does from the same episode with 20 ms at the limits: what a loop winds up
// grows with the time at the limit, its own settling does not. (The settling
// itself, the ring-down of the stage's lightly damped modes, takes longer
// than 5 / f_bw on four of the five loops even after an unsaturated step:
// docs/commissioning.md, "Recovery after saturation".) Without the cascade's
// anti-windup this fails on every stage tried (measured 2026-11-27).
#include <gtest/gtest.h>

#include <cstdio>
#include <stdexcept>
#include <string>

#include "commission/commission.hpp"
#include "commission/recovery.hpp"
#include "commission/sim_stage.hpp"
#include "sim/scenario.hpp"

namespace piezoloop::commission {
namespace {

const std::string kConfigs = std::string(PIEZOLOOP_GOLDEN_DIR) + "/../../configs/";

void expect_recovery(const std::string& file, double range_um) {
    const sim::Scenario truth = sim::load_scenario(kConfigs + file);
    SimStage stage(truth);
    CommissionRequest req;
    req.range_um = range_um;
    const Commissioning c = commission(stage, req);
    ASSERT_GE(c.chosen, 0) << file << ": nothing commissioned";
    const Candidate& k = c.candidates[static_cast<std::size_t>(c.chosen)];
    const sim::Scenario identified = sim::parse_scenario(commissioned_scenario(c), ".");
    RecoveryRequest r;
    r.centre_um = c.centre_um;
    r.range_um = range_um;
    r.bandwidth_Hz = c.measured_bandwidth_Hz > 0.0 ? c.measured_bandwidth_Hz : c.bandwidth_Hz;
    for (const sim::SampleType sample : {sim::SampleType::kFloat, sim::SampleType::kQ31}) {
        r.sample = sample;
        for (const bool on_truth : {false, true}) {
            const sim::Scenario& where_stage = on_truth ? truth : identified;
            const std::string where = file + (on_truth ? ", true stage, " : ", identified stage, ") +
                                      sim::to_string(sample);
            RecoveryRequest step = r;  // a step back from inside the range: the loop's own settling
            step.beyond_um = 0.35 * range_um;
            RecoveryRequest touch = r;  // the same episode, at the limit for 20 ms only
            touch.hold_s = 0.02;
            const RecoveryRun lin = saturation_recovery(where_stage, k.loaded(), step);
            const RecoveryRun brief = saturation_recovery(where_stage, k.loaded(), touch);
            const RecoveryRun sat = saturation_recovery(where_stage, k.loaded(), r);
            std::printf("%s (%s): 5/f_bw %.1f ms; recovery (above / below) after 0.2 s at the limit %.1f / %.1f ms, "
                        "after 20 ms %.1f / %.1f ms, after a step of 35 %% of the range %.1f / %.1f ms\n",
                        where.c_str(), k.name.c_str(), 1e3 * sat.bound_s, 1e3 * sat.episodes[0].recovery_s,
                        1e3 * sat.episodes[1].recovery_s, 1e3 * brief.episodes[0].recovery_s,
                        1e3 * brief.episodes[1].recovery_s, 1e3 * lin.episodes[0].recovery_s,
                        1e3 * lin.episodes[1].recovery_s);
            for (const RecoveryRun* run : {&lin, &brief, &sat}) {
                EXPECT_EQ(run->trip, "none") << where;
                EXPECT_LT(run->settled_error_um, run->tolerance_um) << where << ": not settled before the episodes";
            }
            for (std::size_t i = 0; i < 2; ++i) {
                const std::string ep = where + (i == 0 ? ", above" : ", below");
                EXPECT_LT(lin.episodes[i].clamped_s, 1e-3) << ep << ": the step inside the range saturated";
                EXPECT_GE(lin.episodes[i].recovery_s, 0.0) << ep << ": the step inside the range did not settle";
                EXPECT_GE(brief.episodes[i].clamped_s, 0.5 * touch.hold_s) << ep << ": the command did not saturate";
                EXPECT_GE(brief.episodes[i].recovery_s, 0.0) << ep << ": not back after 20 ms at the limit";
                const RecoveryEpisode& e = sat.episodes[i];
                EXPECT_GE(e.clamped_s, 0.5 * r.hold_s) << ep << ": the command did not saturate";
                EXPECT_GE(e.recovery_s, 0.0) << ep << ": not back within the window";
                EXPECT_LE(e.recovery_s, brief.episodes[i].recovery_s + sat.bound_s) << ep << ": wound up";
            }
        }
    }
}

}  // namespace

TEST(Recovery, StiffStack) { expect_recovery("stages/stiff_stack.json", 12.0); }
TEST(Recovery, SoftBender) { expect_recovery("stages/soft_bender.json", 24.0); }
TEST(Recovery, RhpZero) { expect_recovery("stages/rhp_zero.json", 20.0); }
TEST(Recovery, Ahmad2020) { expect_recovery("ahmad2020.json", 12.0); }
TEST(Recovery, Janaideh2016) { expect_recovery("janaideh2016.json", 20.0); }

TEST(Recovery, BadRequestsNameTheField) {
    const sim::Scenario s = sim::load_scenario(kConfigs + "stages/stiff_stack.json");
    Controller k;
    k.feedback.gain = 1.0;
    RecoveryRequest r;
    r.range_um = 12.0;
    r.bandwidth_Hz = 100.0;
    auto expect_field = [&](const RecoveryRequest& bad, const std::string& field) {
        try {
            saturation_recovery(s, k, bad);
            FAIL() << "expected a refusal naming " << field;
        } catch (const std::invalid_argument& e) {
            EXPECT_EQ(std::string(e.what()).rfind(field, 0), 0u) << e.what();
        }
    };
    RecoveryRequest bad = r;
    bad.range_um = 0.0;
    expect_field(bad, "range_um");
    bad = r;
    bad.bandwidth_Hz = -1.0;
    expect_field(bad, "bandwidth_Hz");
    bad = r;
    bad.bandwidth_Hz = 1.0;  // 5 s bound: beyond the table's 256 levels
    expect_field(bad, "bandwidth_Hz");
    bad = r;
    bad.hold_s = 0.6;
    expect_field(bad, "hold_s");
}

}  // namespace piezoloop::commission
