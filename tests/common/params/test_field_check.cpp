// The field check derived from the groups' declarations
// (common/piezoloop/params/field_check.hpp): paths, ranges and the values
// finite in double but not in float32, which must never reach the core.
#include <gtest/gtest.h>

#include <limits>
#include <string>

#include "piezoloop/params/field_check.hpp"
#include "piezoloop/reference_stage.hpp"
#include "status_text.hpp"

using namespace piezoloop;
using namespace piezoloop::params;

namespace {

template <class G>
std::string check_text(const G& g) {
    FieldCheck c;
    const Status s = c.check(g);
    return s.ok() ? "ok" : describe(s);
}

TEST(ParamsFieldCheck, DefaultsAndTheReferenceSetPass) {
    const PipelineParams p = reference::params(true, true, true);
    EXPECT_EQ(check_text(feedforward_of(p)), "ok");
    EXPECT_EQ(check_text(feedback_of(p)), "ok");
    EXPECT_EQ(check_text(rc_of(p)), "ok");
    EXPECT_EQ(check_text(limits_of(p)), "ok");
    EXPECT_EQ(check_text(TrajectoryParams{}), "ok");
    EXPECT_EQ(check_text(RecorderParams{}), "ok");
}

TEST(ParamsFieldCheck, DoublesBeyondFloatAreRefusedWithTheirPath) {
    FeedbackParams fb;
    for (double bad : {1e39, 3.5e38, 1e300, -1e300}) {
        fb.sos[0].b0 = bad;
        EXPECT_EQ(check_text(fb), "feedback.sections[0].b0: must be finite in float32 (|x| <= 3.4028e+38)") << bad;
    }
    fb.sos[0].b0 = 3.4e38;  // the largest floats are fine
    EXPECT_EQ(check_text(fb), "ok");
    // Sections beyond sos_count are checked too: they are stored and travel.
    fb.sos[3].a2 = 1e39;
    EXPECT_EQ(check_text(fb), "feedback.sections[3].a2: must be finite in float32 (|x| <= 3.4028e+38)");

    RepetitiveParams rc;
    rc.rc.q.b1 = 1e300;
    EXPECT_EQ(check_text(rc), "rc.q.b1: must be finite in float32 (|x| <= 3.4028e+38)");
}

TEST(ParamsFieldCheck, RangesNameTheFieldAndTheAllowedValues) {
    LimitsParams l = limits_of(reference::params());
    l.limits.saturation_trip_s = 2000.0f;
    EXPECT_EQ(check_text(l), "limits.saturation_trip_s: must be in [0, 1000] s");
    l.limits.saturation_trip_s = 0.0f;
    l.limits.slew_V_per_s = 0.0f;
    EXPECT_EQ(check_text(l), "limits.slew_V_per_s: must be in (0, 1e+12] V/s");

    FeedforwardParams ff;
    ff.pi.count = 3;
    ff.pi.thresholds = {0.0f, 1.0f, -2.0f};
    EXPECT_EQ(check_text(ff), "feedforward.pi.thresholds[2]: must be in [0, 3.4028e+38]");
    ff.pi.thresholds[2] = 2.0f;
    ff.pi.weights[1] = std::numeric_limits<float>::quiet_NaN();
    EXPECT_EQ(check_text(ff), "feedforward.pi.weights[1]: must be finite");
    ff.pi.weights[1] = 0.5f;
    ff.pi.count = 17;
    EXPECT_EQ(check_text(ff), "feedforward.pi.count: must be in [0, 16]");

    FeedbackParams fb;
    fb.kind = static_cast<FeedbackKind>(7);
    EXPECT_EQ(check_text(fb), "feedback.kind: must be one of none, sos, pid");
    fb.kind = FeedbackKind::kPid;
    fb.pid.kp = -1.0f;
    EXPECT_EQ(check_text(fb), "feedback.pid.kp: must be in [0, 3.4028e+38] V/um");

    TrajectoryParams t;
    t.frequency_Hz = 0.0f;
    EXPECT_EQ(check_text(t), "trajectory.frequency_Hz: must be in (0, 3.4028e+38] Hz");
    t.frequency_Hz = 1.0f;
    t.start_phase_cycles = 1.0f;
    EXPECT_EQ(check_text(t), "trajectory.start_phase_cycles: must be in [0, 1)");

    RecorderParams r;
    r.channel_count = 2;
    r.channels = {0, 9};
    EXPECT_EQ(check_text(r), "recorder.channels[1]: must be one of r, y, e, u, u_ff, u_fb, u_rc, d, sync");
    r.channels = {0, 1};
    r.decimation = 0;
    EXPECT_EQ(check_text(r), "recorder.decimation: must be in [1, 4294967295] ticks");
}

TEST(ParamsFieldCheck, FirstCriticalChangeFollowsTheDeclaration) {
    TextBuffer<32> out;
    FeedbackParams a, b;
    EXPECT_EQ(first_critical_change(a, b, out), nullptr);
    b.pid.kp = 3.0f;  // a tuning value
    EXPECT_EQ(first_critical_change(a, b, out), nullptr);
    b.pid.u_max = 5.0f;
    EXPECT_STREQ(first_critical_change(a, b, out), "pid.u_max");
    b.sos_count = 2;
    EXPECT_STREQ(first_critical_change(a, b, out), "sos_count");
    LimitsParams l1, l2;
    l2.limits.saturation_trip_s = std::numeric_limits<float>::quiet_NaN();
    EXPECT_STREQ(first_critical_change(l1, l2, out), "saturation_trip_s");  // NaN is never unchanged
    RepetitiveParams r1, r2;
    r2.rc.k_rc = 1.5f;
    EXPECT_EQ(first_critical_change(r1, r2, out), nullptr);
    r2.enabled = true;
    EXPECT_STREQ(first_critical_change(r1, r2, out), "enabled");
}

}  // namespace
