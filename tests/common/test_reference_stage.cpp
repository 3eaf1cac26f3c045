// The reference loop's repetitive controller (reference_stage.hpp): with the
// published Q (cutoff ~7 kHz) the RC is unstable in the reference loop, with
// all_blocks_params()'s Q at 200 Hz it is stable -- for every local slope of
// the stage's hysteresis the all-blocks case's command engages. Judged by the
// host's RC analysis (host/analysis/rc_analysis.hpp, itself tested against
// closed-form cases): its exact answer (the largest root of 1 - M from a
// state-space realisation) and its small-gain bound.
#include <vector>

#include <gtest/gtest.h>

#include "analysis/rc_analysis.hpp"
#include "lti/lti_convert.hpp"
#include "piezoloop/reference_stage.hpp"

using namespace piezoloop;
using namespace piezoloop::design;

namespace {

constexpr double kTs = 1.0 / static_cast<double>(reference::kRate_Hz);

Tf section_tf(const SosSection& s) { return Tf{{s.b0, s.b1, s.b2}, {1.0, s.a1, s.a2}, kTs}; }

// Loop gain of the feedback around the feedforward, linearised: the
// controller's sections, the hysteresis' local slope (µm/V), the stage's
// resonance and the tick's one sample of compute delay.
Ss loop_gain(double slope_um_per_V) {
    SosSection c[3];
    reference::feedback_sections(c);
    Tf l = section_tf(c[0]);
    l = series(l, section_tf(c[1]));
    l = series(l, section_tf(c[2]));
    l = series(l, section_tf(reference::plant().dynamics[0]));
    l = series(l, Tf{{slope_um_per_V}, {1.0, 0.0}, kTs});  // slope z^-1
    return tf2ss(l);
}

RcConfig rc_config(const RepetitiveConfig& p) {
    RcConfig rc;
    rc.period_samples = p.period_samples;
    rc.m1 = p.m1;
    rc.m2 = p.m2;
    rc.k_rc = p.k_rc;
    // Q = b1 / (z + a1): the first-order form both Qs have.
    EXPECT_EQ(p.q.b0, 0.0);
    EXPECT_EQ(p.q.b2, 0.0);
    EXPECT_EQ(p.q.a2, 0.0);
    rc.q.poles = {-p.q.a1};
    rc.q.gain = p.q.b1;
    rc.q.ts = kTs;
    return rc;
}

// The local slopes of the simulated stage's PI model that the case's
// command engages: p0 after a reversal, plus each play operator's weight
// once the input has travelled twice its threshold. The command stays
// within ±4.1 V (the self-test prints u_max_abs_V 4.06), so operators with
// thresholds up to 4.1 V engage.
std::vector<double> local_slopes() {
    const PiModel m = reference::true_stage_model();
    std::vector<double> out{m.p0};
    double slope = m.p0;
    for (int j = 0; j < m.count && m.thresholds[static_cast<unsigned>(j)] < 4.1f; ++j) {
        slope += m.weights[static_cast<unsigned>(j)];
        out.push_back(slope);
    }
    return out;
}

}  // namespace

TEST(ReferenceStage, AllBlocksRcIsStableInTheReferenceLoop) {
    const RcConfig rc = rc_config(reference::all_blocks_params().rc);
    const std::vector<double> slopes = local_slopes();
    ASSERT_GE(slopes.size(), 5u);
    for (double slope : slopes) {
        const RcAnalysis a = analyze_rc_loop_gain(loop_gain(slope), rc);
        EXPECT_TRUE(a.loop_stable) << slope;
        ASSERT_TRUE(a.rc_stable.has_value()) << slope;
        EXPECT_TRUE(*a.rc_stable) << slope << " um/V: largest root " << a.rc_max_abs_root.value_or(-1.0);
        // Sufficient condition too, with margin (0.65-0.75 over these slopes).
        EXPECT_TRUE(a.small_gain_ok) << slope;
        EXPECT_LT(a.small_gain_peak, 0.8) << slope;
        // Condition (3): Q's cutoff below where the phase reaches 90°.
        EXPECT_TRUE(a.phase_ok) << slope << " um/V: 90 deg at " << a.phase_90_at_Hz.value_or(-1.0) << " Hz";
    }
}

TEST(ReferenceStage, PublishedQDivergesInTheReferenceLoop) {
    const RcConfig rc = rc_config(reference::params(true, true, true).rc);
    for (double slope : local_slopes()) {
        const RcAnalysis a = analyze_rc_loop_gain(loop_gain(slope), rc);
        EXPECT_TRUE(a.loop_stable) << slope;
        ASSERT_TRUE(a.rc_stable.has_value()) << slope;
        EXPECT_FALSE(*a.rc_stable) << slope << " um/V: largest root " << a.rc_max_abs_root.value_or(-1.0);
        EXPECT_FALSE(a.small_gain_ok) << slope;
        EXPECT_GT(a.small_gain_peak, 1.1) << slope;
    }
}
