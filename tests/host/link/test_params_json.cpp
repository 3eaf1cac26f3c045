// JSON of the link's parameter groups (host/link/params_json.hpp) and the
// physical value of a log sample. Exact comparisons: a float goes through
// a JSON double and back unchanged (every float is a double), and Q31
// samples scale by a power of two.
#include <gtest/gtest.h>

#include <string>

#include "link/client.hpp"
#include "link/params_json.hpp"
#include "piezoloop/reference_stage.hpp"

using namespace piezoloop;
using namespace piezoloop::hostlink;
using nlohmann::json;

namespace {

std::string error_of(const json& j, link::LimitsParams g) {
    try {
        merge_json(j, g);
    } catch (const std::invalid_argument& e) {
        return e.what();
    }
    return "accepted";
}

template <class G>
G through_text(const G& g) {
    // Printed and parsed again, as `get` > file > `set --json` does.
    const json j = json::parse(to_json(g).dump());
    G out{};
    merge_json(j, out);
    return out;
}

TEST(HostLinkParamsJson, EveryGroupSurvivesTextBitForBit) {
    const PipelineParams p = reference::params(true, true, true);
    const link::FeedforwardParams ff{p.feedforward, p.pi, p.dahl};
    EXPECT_EQ(through_text(ff), ff);
    link::FeedbackParams fb{p.feedback, p.sos_count, p.sos, p.pid};
    // Sections beyond sos_count do not travel in JSON: they come back at
    // their defaults, which is what the reference has.
    EXPECT_EQ(through_text(fb), fb);
    const link::RepetitiveParams rc{p.rc_enabled, p.rc};
    EXPECT_EQ(through_text(rc), rc);
    const link::LimitsParams lim{p.limits};
    EXPECT_TRUE(through_text(lim) == lim);
    link::TrajectoryParams t;
    t.waveform = Waveform::kTable;
    t.amplitude_um = 1.0f / 3.0f;
    t.offset_um = 0.1f;
    t.frequency_Hz = 12.5f;
    t.table_count = 3;
    t.table[0] = -1.0f;
    t.table[1] = 0.3f;
    t.table[2] = 1.0f;
    EXPECT_EQ(through_text(t), t);
    link::RecorderParams r;
    r.channel_count = 4;
    r.channels = {0, 1, 2, 3};
    r.decimation = 7;
    r.mode = RecordMode::kSingleShot;
    r.trigger = TriggerMode::kFalling;
    r.trigger_signal = 5;
    r.trigger_level = -0.7f;
    r.pre_trigger = 10;
    r.length = 100;
    EXPECT_EQ(through_text(r), r);
}

TEST(HostLinkParamsJson, SeriesPlacementHasItsName) {
    // The kind travels as its enum value; its JSON name is "pi_series".
    link::FeedforwardParams ff{FeedforwardKind::kPiSeries, reference::params().pi, {}};
    EXPECT_EQ(to_json(ff).at("kind"), "pi_series");
    EXPECT_EQ(through_text(ff), ff);
    link::FeedforwardParams g;
    merge_json(json::parse(R"({"kind": "pi_series"})"), g);
    EXPECT_EQ(g.kind, FeedforwardKind::kPiSeries);
}

TEST(HostLinkParamsJson, MergeChangesOnlyTheGivenKeys) {
    link::LimitsParams g{reference::params().limits};
    const link::LimitsParams before = g;
    merge_json(json::parse(R"({"u_max_V": 5})"), g);
    EXPECT_EQ(g.limits.u_max_V, 5.0f);
    EXPECT_EQ(g.limits.u_min_V, before.limits.u_min_V);
    EXPECT_EQ(g.limits.slew_V_per_s, before.limits.slew_V_per_s);
    EXPECT_EQ(g.limits.saturation_trip_s, before.limits.saturation_trip_s);
}

TEST(HostLinkParamsJson, ErrorsNameTheKey) {
    EXPECT_EQ(error_of(json::parse(R"({"u_max": 5})"), {}), "limits.u_max: unknown field (allowed here: u_min_V, u_max_V, slew_V_per_s, saturation_trip_s)");
    EXPECT_EQ(error_of(json::parse(R"({"u_max_V": "5"})"), {}), "limits.u_max_V: must be a number, not a string");
    EXPECT_EQ(error_of(json::parse("[1]"), {}), "limits: must be a JSON object");
    link::FeedforwardParams ff;
    try {
        merge_json(json::parse(R"({"kind": "inverse"})"), ff);
        FAIL();
    } catch (const std::invalid_argument& e) {
        EXPECT_STREQ(e.what(), "feedforward.kind: must be one of none|pi_inverse|pi_compensator|dahl|pi_series (got \"inverse\")");
    }
    try {
        merge_json(json::parse(R"({"pi": {"thresholds": [0, 1], "weights": [1]}})"), ff);
        FAIL();
    } catch (const std::invalid_argument& e) {
        EXPECT_STREQ(e.what(), "feedforward.pi.weights: must have as many values as thresholds");
    }
    link::RecorderParams r;
    try {
        merge_json(json::parse(R"({"channels": ["r", "x"]})"), r);
        FAIL();
    } catch (const std::invalid_argument& e) {
        EXPECT_STREQ(e.what(), "recorder.channels[1]: must be one of r|y|e|u|u_ff|u_fb|u_rc|d|sync (got \"x\")");
    }
    EXPECT_THROW(parse_group("gains"), std::invalid_argument);
    EXPECT_EQ(parse_group("rc"), link::ParamGroup::kRepetitive);
}

TEST(HostLinkLogSample, Q31ScalesByTheHelloFullScale) {
    link::HelloReply h;
    h.position_full_scale_um = 40.0f;
    h.voltage_full_scale_V = 150.0f;
    // 2^30 is half of full scale; -2^31 is minus full scale (exact in double).
    EXPECT_EQ(log_sample_physical(0x40000000u, 0, link::SampleFormat::kQ31, h), 20.0);
    EXPECT_EQ(log_sample_physical(0x80000000u, 2, link::SampleFormat::kQ31, h), -40.0);
    EXPECT_EQ(log_sample_physical(0x40000000u, 3, link::SampleFormat::kQ31, h), 75.0);  // u: volts
    EXPECT_EQ(log_sample_physical(std::bit_cast<uint32_t>(1.25f), 1, link::SampleFormat::kFloat32, h), 1.25);
    EXPECT_STREQ(signal_unit(2), "um");
    EXPECT_STREQ(signal_unit(6), "V");
    EXPECT_STREQ(signal_name(4), "u_ff");
}

}  // namespace
