// The device-side dispatcher against a real Pipeline<float> and Pipeline<Q31>
// with the reference setup: every request gets its reply, rejected requests
// name the offending field and leave the state unchanged (checked by
// read-back), and hostile input is counted and dropped while the device keeps
// running. Exact comparisons throughout: the link moves bit patterns, and the
// read-back returns the stored parameter set, not a recomputation.
#include <gtest/gtest.h>

#include <cstring>
#include <limits>
#include <random>
#include <string>
#include <utility>
#include <vector>

#include "test_link_client.hpp"

using namespace link_test;

namespace {

template <class T>
class LinkDevice : public ::testing::Test {
protected:
    Rig<T> rig;

    // Limits and the reference controller in place, one tick to swap them in.
    void configure_reference() {
        const PipelineParams p = reference::params(true, true, false);
        ASSERT_EQ(rig.set(LimitsParams{p.limits}).type(), MsgType::kAck);
        rig.tick();
        ASSERT_EQ(rig.set(FeedforwardParams{p.feedforward, p.pi, p.dahl}).type(), MsgType::kAck);
        rig.tick();
        ASSERT_EQ(rig.set(FeedbackParams{p.feedback, p.sos_count, p.sos, p.pid}).type(), MsgType::kAck);
        rig.tick();
    }

    void expect_error(const Reply& r, ErrorCode code, const char* group, const char* field, int index = -1) {
        ASSERT_EQ(r.type(), MsgType::kError);
        const ErrorReply e = r.template as<ErrorReply>();
        EXPECT_EQ(e.code, code) << error_code_name(e.code) << ": " << e.message.data();
        if (group != nullptr) {
            EXPECT_STREQ(e.group.data(), group);
        }
        if (field != nullptr) {
            EXPECT_STREQ(e.field.data(), field);
        }
        EXPECT_EQ(e.index, index);
        EXPECT_GT(std::strlen(e.message.data()), 0u);
    }

    // Everything a read-back can see, as encoded bytes.
    std::vector<std::vector<uint8_t>> snapshot() {
        std::vector<std::vector<uint8_t>> s;
        for (int g = 1; g <= 6; ++g) {
            const Reply r = rig.request(GetParams{static_cast<ParamGroup>(g)});
            EXPECT_EQ(r.type(), MsgType::kParamsReply);
            s.push_back(r.body);
        }
        const StatusReply st = rig.request(GetStatus{}).template as<StatusReply>();
        s.push_back({st.armed, st.tripped, static_cast<uint8_t>(st.trip_reason), st.wave_running, st.streaming});
        return s;
    }
};

using SampleTypes = ::testing::Types<float, Q31>;
TYPED_TEST_SUITE(LinkDevice, SampleTypes);

}  // namespace

TYPED_TEST(LinkDevice, HelloStatesIdentityAndLimits) {
    const Reply r = this->rig.request(Hello{});
    const HelloReply h = r.template as<HelloReply>();
    EXPECT_EQ(h.protocol_version, kProtocolVersion);
    EXPECT_STREQ(h.board.data(), "test-board");
    EXPECT_STREQ(h.firmware_version.data(), "1.2.3");
    EXPECT_STREQ(h.serial.data(), "SN0001");
    const PipelineSetup s = reference::setup();
    EXPECT_EQ(h.loop_rate_Hz, s.rate_Hz);
    EXPECT_EQ(h.hard_u_min_V, s.hard.u_min_V);
    EXPECT_EQ(h.hard_u_max_V, s.hard.u_max_V);
    EXPECT_EQ(h.hard_slew_max_V_per_s, s.hard.slew_max_V_per_s);
    EXPECT_EQ(h.position_full_scale_um, s.position.full_scale);
    EXPECT_EQ(h.voltage_full_scale_V, s.voltage.full_scale);
    constexpr bool is_float = std::is_same_v<TypeParam, float>;
    EXPECT_EQ(h.sample_format, is_float ? SampleFormat::kFloat32 : SampleFormat::kQ31);
    EXPECT_NE(h.capabilities & cap::kDahl, 0u);  // both pipelines run Dahl feedforward
    EXPECT_EQ(h.recorder_channels, 4);
    // A hello in a future version is still answered, in ours.
    std::vector<uint8_t> raw(kMaxFrameSize);
    const std::size_t n = encode_message(Hello{}, 9, raw, 7);
    raw.resize(n);
    const auto rs = this->rig.send_bytes(raw);
    ASSERT_EQ(rs.size(), 1u);
    EXPECT_EQ(rs[0].type(), MsgType::kHelloReply);
    EXPECT_EQ(rs[0].header.version, kProtocolVersion);
}

TYPED_TEST(LinkDevice, SetAndReadBackEveryGroup) {
    auto& r_ = this->rig;
    this->configure_reference();
    const PipelineParams p = reference::params(true, true, false);
    EXPECT_EQ(r_.template get<LimitsParams>(ParamGroup::kLimits), LimitsParams{p.limits});
    EXPECT_EQ(r_.template get<FeedforwardParams>(ParamGroup::kFeedforward), (FeedforwardParams{p.feedforward, p.pi, p.dahl}));
    EXPECT_EQ(r_.template get<FeedbackParams>(ParamGroup::kFeedback), (FeedbackParams{p.feedback, p.sos_count, p.sos, p.pid}));
    // What the pipeline runs is what was sent.
    EXPECT_EQ(r_.pipeline->params().pi, p.pi);
    EXPECT_EQ(r_.pipeline->params().sos, p.sos);

    RepetitiveParams rc{true, reference::params(true, true, true).rc};
    EXPECT_EQ(r_.set(rc).type(), MsgType::kAck);
    r_.tick();
    EXPECT_EQ(r_.template get<RepetitiveParams>(ParamGroup::kRepetitive), rc);

    TrajectoryParams tp;
    tp.waveform = Waveform::kTable;
    tp.amplitude_um = 12.0f;
    tp.offset_um = 1.0f;
    tp.frequency_Hz = 10.0f;
    tp.cycles = 3;
    tp.table_count = 5;
    tp.table = {0.0f, 0.5f, 1.0f, -0.5f, -1.0f};
    EXPECT_EQ(r_.set(tp).type(), MsgType::kAck);
    EXPECT_EQ(r_.template get<TrajectoryParams>(ParamGroup::kTrajectory), tp);

    RecorderParams rp;
    rp.channel_count = 4;
    rp.channels = {0, 1, 2, 3};
    rp.decimation = 2;
    rp.mode = RecordMode::kSingleShot;
    rp.trigger = TriggerMode::kRising;
    rp.trigger_signal = 0;
    rp.trigger_level = 0.5f;
    rp.pre_trigger = 10;
    rp.length = 100;
    EXPECT_EQ(r_.set(rp).type(), MsgType::kAck);
    EXPECT_EQ(r_.template get<RecorderParams>(ParamGroup::kRecorder), rp);

    // Unknown groups are refused, by get and by set.
    this->expect_error(r_.request(GetParams{static_cast<ParamGroup>(params::kGroupCount + 1)}), ErrorCode::kBadGroup,
                       nullptr, "group");
}

TYPED_TEST(LinkDevice, InvalidParametersNameTheFieldAndChangeNothing) {
    auto& r_ = this->rig;
    this->configure_reference();
    const auto before = this->snapshot();
    const PipelineParams p = reference::params(true, true, false);
    const float nan = std::numeric_limits<float>::quiet_NaN();

    FeedforwardParams ff{p.feedforward, p.pi, p.dahl};
    ff.pi.weights[3] = nan;
    this->expect_error(r_.set(ff), ErrorCode::kInvalidParam, "feedforward", "pi.weights", 3);
    ff = {p.feedforward, p.pi, p.dahl};
    ff.pi.thresholds[5] = ff.pi.thresholds[4];  // not ascending
    this->expect_error(r_.set(ff), ErrorCode::kInvalidParam, "feedforward", "pi.thresholds", 5);
    // A pre-filter coefficient, non-finite (the field check) or making an
    // unstable section (the core): both named as the group holds it.
    ff = {p.feedforward, p.pi, p.dahl};
    ff.prefilter_count = 2;
    ff.prefilter[0] = ff.prefilter[1] = SosSection{0.02, 0.04, 0.02, -1.56, 0.64};
    ff.prefilter[1].b0 = std::numeric_limits<double>::infinity();
    this->expect_error(r_.set(ff), ErrorCode::kInvalidParam, "feedforward", "prefilter[1].b0");
    ff.prefilter[1] = SosSection{0.02, 0.04, 0.02, -1.56, 0.64};
    ff.prefilter[1].a2 = 1.25;  // a pole outside the unit circle
    this->expect_error(r_.set(ff), ErrorCode::kInvalidParam, "feedforward", "prefilter[1].a2");

    FeedbackParams fb{p.feedback, p.sos_count, p.sos, p.pid};
    fb.sos[1].a2 = std::numeric_limits<double>::quiet_NaN();
    this->expect_error(r_.set(fb), ErrorCode::kInvalidParam, "feedback", "sections[1].a2");
    fb = {p.feedback, p.sos_count, p.sos, p.pid};
    fb.sos[0].a2 = 1.5;  // a pole outside the unit circle
    const Reply unstable = r_.set(fb);
    this->expect_error(unstable, ErrorCode::kInvalidParam, "feedback", "sections[0].a2", -1);
    fb = {FeedbackKind::kPid, p.sos_count, p.sos, p.pid};
    fb.pid.kp = 0.5f;
    fb.pid.kd_s = 1e-6f;
    fb.pid.derivative_cutoff_Hz = 3.0e6f;  // above half the loop rate: the core's check
    this->expect_error(r_.set(fb), ErrorCode::kInvalidParam, "feedback", "pid.derivative_cutoff_Hz", -1);

    LimitsParams lim{p.limits};
    lim.limits.u_max_V = 11.0f;  // above the hard limit of 10 V
    this->expect_error(r_.set(lim), ErrorCode::kInvalidParam, "limits", "u_max_V");
    lim = LimitsParams{p.limits};
    lim.limits.slew_V_per_s = nan;
    this->expect_error(r_.set(lim), ErrorCode::kInvalidParam, "limits", "slew_V_per_s");

    RepetitiveParams rc{true, p.rc};
    rc.rc.k_rc = 2.5f;
    this->expect_error(r_.set(rc), ErrorCode::kInvalidParam, "rc", "k_rc");
    rc = {true, p.rc};
    rc.rc.q.b1 = std::numeric_limits<double>::infinity();
    this->expect_error(r_.set(rc), ErrorCode::kInvalidParam, "rc", "q.b1");

    TrajectoryParams tp;
    tp.frequency_Hz = 60000.0f;  // above Nyquist
    this->expect_error(r_.set(tp), ErrorCode::kInvalidParam, "trajectory", "frequency_Hz");
    tp = TrajectoryParams{};
    tp.amplitude_um = nan;
    this->expect_error(r_.set(tp), ErrorCode::kInvalidParam, "trajectory", "amplitude_um");

    RecorderParams rp;
    rp.channel_count = 4;
    rp.channels = {0, 1, 2, 9};
    this->expect_error(r_.set(rp), ErrorCode::kInvalidParam, "recorder", "channels", 3);
    rp.channel_count = 3;
    this->expect_error(r_.set(rp), ErrorCode::kUnsupported, "recorder", "channel_count");

    FeedforwardParams dahl{FeedforwardKind::kDahl, p.pi, kAhmad2020Dahl};
    dahl.dahl.alpha2 = 0.0f;
    this->expect_error(r_.set(dahl), ErrorCode::kInvalidParam, "feedforward", "dahl.alpha2");
    r_.tick(3);
    EXPECT_EQ(this->snapshot(), before);
    EXPECT_EQ(r_.pipeline->swaps(), 3u);  // the three accepted sets of configure_reference()
}

// A fresh board's recorder group is a valid set: a client that changes one
// field of it (as `set recorder --json '{"decimation": 2}'` does) is checked
// on that field only; the recorder is configured only once it is set.
TYPED_TEST(LinkDevice, AFreshRecorderGroupIsAValidSetToChange) {
    auto& r_ = this->rig;
    RecorderParams rp = r_.template get<RecorderParams>(ParamGroup::kRecorder);
    EXPECT_EQ(rp.channel_count, r_.device->make_hello().recorder_channels);
    this->expect_error(r_.request(RecorderArm{}), ErrorCode::kNotConfigured, "recorder", "channels");
    for (const uint32_t decimation : {2u, 7u, 0xffffffffu}) {
        rp.decimation = decimation;
        ASSERT_EQ(r_.set(rp).type(), MsgType::kAck) << decimation;
        EXPECT_EQ(r_.template get<RecorderParams>(ParamGroup::kRecorder), rp);
    }
    EXPECT_EQ(r_.request(RecorderArm{}).type(), MsgType::kAck);
}

TYPED_TEST(LinkDevice, ModifiedPiCompensatorTravelsAndABadMapIsRefused) {
    // The compensator's input map (dead zones) travels in the feedforward
    // group's pi and runs; a map that falls, or dead zones on a model the
    // device is asked to invert, are refused by name and change nothing.
    auto& r_ = this->rig;
    this->configure_reference();
    const PipelineParams p = reference::params(true, true, false);
    FeedforwardParams zones{FeedforwardKind::kPiCompensator, p.pi, p.dahl};
    zones.pi.dead_zones = 2;
    zones.pi.dead_zone_thresholds = {-5.0f, 5.0f};
    zones.pi.dead_zone_weights = {0.5f, -0.25f};
    ASSERT_EQ(r_.set(zones).type(), MsgType::kAck);
    r_.tick();
    EXPECT_EQ(r_.template get<FeedforwardParams>(ParamGroup::kFeedforward), zones);
    EXPECT_EQ(r_.pipeline->params().pi.dead_zones, 2);
    const auto before = this->snapshot();
    FeedforwardParams falling = zones;
    falling.pi.dead_zone_weights[0] = -1.5f;  // slope 1 - 1.5 < 0 after -5 um
    this->expect_error(r_.set(falling), ErrorCode::kInvalidParam, "feedforward", "pi.dead_zone_weights", 0);
    FeedforwardParams inverse = zones;
    inverse.kind = FeedforwardKind::kPiInverse;
    this->expect_error(r_.set(inverse), ErrorCode::kInvalidParam, "feedforward", "pi.dead_zones");
    r_.tick();
    EXPECT_EQ(this->snapshot(), before);
}

TYPED_TEST(LinkDevice, SeriesPlacementTravelsAndNeedsAFeedback) {
    // pi_series (the compensator after the feedback) is one more kind value:
    // same layout, validated by the pipeline on the device.
    auto& r_ = this->rig;
    this->configure_reference();
    const PipelineParams p = reference::params(true, true, false);
    const FeedforwardParams series{FeedforwardKind::kPiSeries, p.pi, p.dahl};
    ASSERT_EQ(r_.set(series).type(), MsgType::kAck);
    r_.tick();
    EXPECT_EQ(r_.template get<FeedforwardParams>(ParamGroup::kFeedforward), series);
    EXPECT_EQ(r_.pipeline->params().feedforward, FeedforwardKind::kPiSeries);
    // Without a feedback there is nothing to put the compensator after: the
    // feedback group cannot be switched off under it, nothing changes.
    const auto before = this->snapshot();
    FeedbackParams none{FeedbackKind::kNone, p.sos_count, p.sos, p.pid};
    this->expect_error(r_.set(none), ErrorCode::kInvalidParam, nullptr, "feedforward");
    r_.tick();
    EXPECT_EQ(this->snapshot(), before);
    // Kind values past pi_series are still refused, by their declared names.
    const FeedforwardParams unknown{static_cast<FeedforwardKind>(5), p.pi, p.dahl};
    this->expect_error(r_.set(unknown), ErrorCode::kInvalidParam, "feedforward", "kind");
}

TYPED_TEST(LinkDevice, LimitCriticalChangesOnlyWhileDisarmed) {
    auto& r_ = this->rig;
    this->configure_reference();
    const PipelineParams p = reference::params(true, true, false);
    EXPECT_EQ(r_.request(Arm{}).type(), MsgType::kAck);
    r_.tick(10);
    const auto before = this->snapshot();

    LimitsParams lim{p.limits};
    lim.limits.u_max_V = 5.0f;  // even narrowing: limits are refused while armed
    this->expect_error(r_.set(lim), ErrorCode::kArmed, "limits", "u_max_V");
    // Resending the same limits is harmless.
    EXPECT_EQ(r_.set(LimitsParams{p.limits}).type(), MsgType::kAck);
    FeedbackParams fb{FeedbackKind::kPid, p.sos_count, p.sos, p.pid};
    this->expect_error(r_.set(fb), ErrorCode::kArmed, "feedback", "kind");
    fb = {p.feedback, 2, p.sos, p.pid};
    this->expect_error(r_.set(fb), ErrorCode::kArmed, "feedback", "sos_count");
    fb = {p.feedback, p.sos_count, p.sos, p.pid};
    fb.pid.u_max = 100.0f;
    this->expect_error(r_.set(fb), ErrorCode::kArmed, "feedback", "pid.u_max");
    FeedforwardParams ff{FeedforwardKind::kNone, p.pi, p.dahl};
    this->expect_error(r_.set(ff), ErrorCode::kArmed, "feedforward", "kind");
    this->expect_error(r_.set(RepetitiveParams{true, p.rc}), ErrorCode::kArmed, "rc", "enabled");
    this->expect_error(r_.request(ClearTrip{}), ErrorCode::kArmed, "limits", "trip");
    r_.tick(10);
    EXPECT_EQ(this->snapshot(), before);
    EXPECT_TRUE(r_.pipeline->armed());

    // Tuning is allowed while armed: a changed SOS gain is swapped in.
    fb = {p.feedback, p.sos_count, p.sos, p.pid};
    fb.sos[0].b0 *= 0.5;
    fb.sos[0].b1 *= 0.5;
    fb.sos[0].b2 *= 0.5;
    EXPECT_EQ(r_.set(fb).type(), MsgType::kAck);
    // A second set before the swap is refused as busy, and changes nothing.
    this->expect_error(r_.set(FeedbackParams{p.feedback, p.sos_count, p.sos, p.pid}), ErrorCode::kBusy, "feedback", "params");
    r_.tick();
    EXPECT_EQ(r_.template get<FeedbackParams>(ParamGroup::kFeedback), fb);

    // Disarmed, the limits change.
    EXPECT_EQ(r_.request(Disarm{}).type(), MsgType::kAck);
    lim.limits.u_max_V = 5.0f;
    EXPECT_EQ(r_.set(lim).type(), MsgType::kAck);
    r_.tick();
    EXPECT_EQ(r_.template get<LimitsParams>(ParamGroup::kLimits), lim);
    EXPECT_EQ(r_.pipeline->limiter().config().u_max_V, 5.0f);
}

TYPED_TEST(LinkDevice, ArmRefusedWhileTripped) {
    auto& r_ = this->rig;
    // No limits yet: the limiter is tripped (not configured).
    this->expect_error(r_.request(Arm{}), ErrorCode::kTripped, "limits", "trip");
    EXPECT_FALSE(r_.pipeline->armed());
    this->configure_reference();
    EXPECT_EQ(r_.request(Arm{}).type(), MsgType::kAck);
    r_.tick();
    r_.pipeline->limiter().trip();
    EXPECT_EQ(r_.request(Disarm{}).type(), MsgType::kAck);
    this->expect_error(r_.request(Arm{}), ErrorCode::kTripped, "limits", "trip");
    EXPECT_EQ(r_.request(ClearTrip{}).type(), MsgType::kAck);
    EXPECT_EQ(r_.request(Arm{}).type(), MsgType::kAck);
    const StatusReply st = r_.request(GetStatus{}).template as<StatusReply>();
    EXPECT_TRUE(st.armed);
    EXPECT_FALSE(st.tripped);
}

TYPED_TEST(LinkDevice, UnknownVersionAndMalformedRequestsGetErrorsAndAreCounted) {
    auto& r_ = this->rig;
    this->configure_reference();
    const auto before = this->snapshot();
    std::vector<uint8_t> f(kMaxFrameSize);

    for (const uint8_t type : {uint8_t{0x00}, uint8_t{0x3F}, uint8_t{0x42}, uint8_t{0x80}, uint8_t{0xC0}, uint8_t{0xFF}}) {
        const std::size_t n = encode_frame(type, kProtocolVersion, 77, {}, f);
        const auto rs = r_.send_bytes(std::span<const uint8_t>(f.data(), n));
        ASSERT_EQ(rs.size(), 1u);
        EXPECT_EQ(rs[0].header.seq, 77);
        this->expect_error(rs[0], ErrorCode::kUnknownType, nullptr, "type");
        EXPECT_EQ(rs[0].template as<ErrorReply>().request_type, type);
    }
    EXPECT_EQ(r_.device->counters().unknown_type, 6u);

    std::size_t n = encode_message(GetStatus{}, 5, f, static_cast<uint8_t>(kProtocolVersion + 1));
    auto rs = r_.send_bytes(std::span<const uint8_t>(f.data(), n));
    ASSERT_EQ(rs.size(), 1u);
    this->expect_error(rs[0], ErrorCode::kBadVersion, nullptr, "version");
    EXPECT_EQ(r_.device->counters().bad_version, 1u);

    const std::vector<uint8_t> extra{1, 2, 3};
    n = encode_frame(static_cast<uint8_t>(MsgType::kArm), kProtocolVersion, 6, extra, f);
    rs = r_.send_bytes(std::span<const uint8_t>(f.data(), n));
    ASSERT_EQ(rs.size(), 1u);
    this->expect_error(rs[0], ErrorCode::kMalformed, nullptr, "body");
    EXPECT_EQ(r_.device->counters().bad_length, 1u);
    EXPECT_FALSE(r_.pipeline->armed());

    const std::vector<uint8_t> short_limits{static_cast<uint8_t>(ParamGroup::kLimits), 0, 0};
    n = encode_frame(static_cast<uint8_t>(MsgType::kSetParams), kProtocolVersion, 8, short_limits, f);
    rs = r_.send_bytes(std::span<const uint8_t>(f.data(), n));
    ASSERT_EQ(rs.size(), 1u);
    this->expect_error(rs[0], ErrorCode::kMalformed, nullptr, "body");
    EXPECT_EQ(r_.device->counters().truncated, 1u);

    const std::vector<uint8_t> bad_group{0x33, 1, 2};
    n = encode_frame(static_cast<uint8_t>(MsgType::kSetParams), kProtocolVersion, 9, bad_group, f);
    rs = r_.send_bytes(std::span<const uint8_t>(f.data(), n));
    ASSERT_EQ(rs.size(), 1u);
    this->expect_error(rs[0], ErrorCode::kBadGroup, nullptr, "group");

    // Bad CRC and garbage: no reply, counted.
    n = encode_message(Arm{}, 10, f);
    f[3] ^= 0x40;
    if (f[3] == 0) f[3] = 0x11;
    EXPECT_TRUE(r_.send_bytes(std::span<const uint8_t>(f.data(), n)).empty());
    EXPECT_EQ(r_.device->counters().bad_crc + r_.device->counters().bad_cobs, 1u);
    EXPECT_FALSE(r_.pipeline->armed());

    EXPECT_EQ(this->snapshot(), before);
    const StatusReply st = r_.request(GetStatus{}).template as<StatusReply>();
    EXPECT_EQ(st.link, r_.device->counters());
    EXPECT_NE(st.faults & fault::kLinkErrors, 0u);
}

TYPED_TEST(LinkDevice, SetpointStreamWithFlowControl) {
    using T = TypeParam;
    auto& r_ = this->rig;
    this->configure_reference();
    const SignalScale pos = reference::setup().position;
    auto ack = r_.request(StreamStart{100}).template as<SetpointAck>();
    EXPECT_EQ(ack.next_block_seq, 0u);
    EXPECT_EQ(ack.free, 1024);
    r_.tick(5);  // priming: nothing consumed, no underrun
    EXPECT_EQ(r_.device->setpoint_underruns(), 0u);

    std::vector<float> sent;
    uint32_t seq = 0;
    auto block = [&](int count) {
        SetpointBlock b;
        b.block_seq = seq;
        b.count = static_cast<uint8_t>(count);
        for (int i = 0; i < count; ++i) {
            b.setpoint_um[i] = 0.01f * static_cast<float>(sent.size());
            sent.push_back(b.setpoint_um[i]);
        }
        return b;
    };
    ack = r_.request(block(60)).template as<SetpointAck>();
    ++seq;
    EXPECT_EQ(ack.next_block_seq, 1u);
    EXPECT_EQ(ack.free, 1024 - 60);
    r_.tick();
    EXPECT_EQ(r_.pipeline->last().r, sample_zero<T>());  // still priming (60 < 100)
    ack = r_.request(block(60)).template as<SetpointAck>();
    ++seq;
    // Consumed one per tick, in order, converted to the sample type.
    for (std::size_t i = 0; i < 120; ++i) {
        r_.tick();
        ASSERT_EQ(r_.pipeline->last().r, pos.to_sample<T>(sent[i])) << i;
    }
    EXPECT_EQ(r_.device->setpoint_underruns(), 0u);
    r_.tick(3);  // ran dry: counted, the setpoint holds
    EXPECT_EQ(r_.device->setpoint_underruns(), 3u);
    EXPECT_EQ(r_.pipeline->last().r, pos.to_sample<T>(sent.back()));

    // Out of sequence, NaN, and too many: error, block dropped, sequence kept.
    SetpointBlock wrong = block(10);
    wrong.block_seq = 7;
    this->expect_error(r_.request(wrong), ErrorCode::kSequence, nullptr, "block_seq");
    SetpointBlock bad = block(10);
    bad.setpoint_um[4] = std::numeric_limits<float>::quiet_NaN();
    this->expect_error(r_.request(bad), ErrorCode::kInvalidParam, nullptr, "setpoint_um", 4);
    for (int i = 0; i < 8; ++i) {
        ack = r_.request(block(120)).template as<SetpointAck>();
        ++seq;
    }
    EXPECT_EQ(ack.free, 1024 - 960);
    this->expect_error(r_.request(block(120)), ErrorCode::kNoSpace, nullptr, "count");
    const StatusReply st = r_.request(GetStatus{}).template as<StatusReply>();
    EXPECT_EQ(st.setpoint_next_seq, seq);
    EXPECT_EQ(st.setpoint_underruns, 3u);
    EXPECT_TRUE(st.streaming);

    // Drain: the buffered setpoints are consumed, then the stream ends without underruns.
    EXPECT_EQ(r_.request(StreamStop{true}).type(), MsgType::kAck);
    r_.tick(970);
    EXPECT_FALSE(r_.device->streaming());
    EXPECT_EQ(r_.device->setpoint_underruns(), 3u);
    this->expect_error(r_.request(block(1)), ErrorCode::kNotConfigured, nullptr, "stream");
}

TYPED_TEST(LinkDevice, WaveStartStop) {
    auto& r_ = this->rig;
    this->configure_reference();
    this->expect_error(r_.request(StartWave{}), ErrorCode::kNotConfigured, "trajectory", "waveform");
    TrajectoryParams tp;
    tp.waveform = Waveform::kTriangle;
    tp.amplitude_um = 12.0f;
    tp.frequency_Hz = 10.0f;
    EXPECT_EQ(r_.set(tp).type(), MsgType::kAck);
    EXPECT_EQ(r_.request(StartWave{}).type(), MsgType::kAck);
    // The triangle starts at -12 um, the stage reads 0: N - 1 ticks of
    // approach (12 um at 500 um/s: N = 4500), then a quarter period: r at
    // the triangle's midpoint rising.
    const uint32_t n = r_.pipeline->approach_ticks(sample_zero<TypeParam>());
    EXPECT_NEAR(n, 4500.0, 1.0);
    r_.tick(n - 1 + 2500);
    EXPECT_TRUE(r_.pipeline->wave_running());
    const float r = reference::setup().position.to_physical(r_.pipeline->last().r);
    EXPECT_NEAR(r, 0.0f, 0.01f);  // triangle from -A at phase 0: 0 at 1/4 (one sample = 0.0048 µm)
    this->expect_error(r_.request(StartWave{}), ErrorCode::kBusy, "trajectory", "waveform");
    this->expect_error(r_.request(StreamStart{}), ErrorCode::kBusy, nullptr, "stream");
    EXPECT_EQ(r_.request(StopWave{}).type(), MsgType::kAck);
    r_.tick();
    EXPECT_FALSE(r_.pipeline->wave_running());
}

TYPED_TEST(LinkDevice, RecorderLogStreamCarriesEveryFrame) {
    using T = TypeParam;
    auto& r_ = this->rig;
    this->configure_reference();
    this->expect_error(r_.request(RecorderArm{}), ErrorCode::kNotConfigured, "recorder", "channels");
    RecorderParams rp;
    rp.channel_count = 4;
    rp.channels = {0, 1, 2, 3};
    rp.decimation = 3;
    rp.mode = RecordMode::kContinuous;
    EXPECT_EQ(r_.set(rp).type(), MsgType::kAck);
    TrajectoryParams tp;
    tp.waveform = Waveform::kSine;
    tp.amplitude_um = 5.0f;
    tp.frequency_Hz = 100.0f;
    ASSERT_EQ(r_.set(tp).type(), MsgType::kAck);
    ASSERT_EQ(r_.request(StartWave{}).type(), MsgType::kAck);
    ASSERT_EQ(r_.request(Arm{}).type(), MsgType::kAck);
    EXPECT_EQ(r_.request(RecorderArm{}).type(), MsgType::kAck);

    std::vector<Reply> blocks;
    std::vector<std::array<T, 4>> expected;  // r, y, e, u of every kept tick
    std::vector<uint32_t> ticks;
    auto poll = [&] {
        r_.replies.clear();
        while (r_.device->poll_log(r_.sink())) {}
        blocks.insert(blocks.end(), r_.replies.begin(), r_.replies.end());
    };
    for (int i = 0; i < 3000; ++i) {
        const uint32_t tick = r_.pipeline->tick_count();
        r_.tick();
        const auto& s = r_.pipeline->last();
        if (i % 3 == 0) { expected.push_back({s.r, s.y, s.e, s.u}); ticks.push_back(tick); }
        if (i % 200 == 0) poll();
    }
    EXPECT_EQ(r_.request(RecorderStop{}).type(), MsgType::kAck);
    poll();
    std::size_t k = 0;
    for (std::size_t bi = 0; bi < blocks.size(); ++bi) {
        const LogBlock b = blocks[bi].template as<LogBlock>();
        EXPECT_EQ(b.block_seq, bi);
        EXPECT_EQ(b.channel_count, 4);
        EXPECT_EQ(b.tick_stride, 3u);
        EXPECT_EQ(b.format, (std::is_same_v<T, float> ? SampleFormat::kFloat32 : SampleFormat::kQ31));
        EXPECT_EQ(b.recorder_overruns, 0u);
        ASSERT_LT(k, ticks.size());
        EXPECT_EQ(b.first_tick, ticks[k]);
        for (std::size_t f = 0; f < b.frame_count; ++f, ++k)
            for (std::size_t c = 0; c < 4; ++c) {
                T v;
                if constexpr (std::is_same_v<T, float>) v = std::bit_cast<float>(b.samples[f * 4 + c]);
                else v = Q31::from_raw(static_cast<int32_t>(b.samples[f * 4 + c]));
                ASSERT_EQ(v, expected[k][c]) << "frame " << k << " channel " << c;
            }
    }
    EXPECT_EQ(k, expected.size());
    EXPECT_GE(blocks.size(), expected.size() / Device<T>::kFramesPerBlock);
}

TYPED_TEST(LinkDevice, HostileStreamIsCountedAndTheDeviceKeepsRunning) {
    // Property test: 1e5 frames, each random garbage, a well-framed request of
    // random type and random body, or a damaged copy of a valid request.
    auto& r_ = this->rig;
    this->configure_reference();
    const auto before = this->snapshot();
    const LinkCounters c0 = r_.device->counters();
    std::mt19937 rng(2026);
    std::size_t chunks = 0, replies = 0, good_frames = 0;
    std::vector<uint8_t> f(kMaxFrameSize), body;
    std::vector<uint8_t> stream;
    constexpr int kFrames = 100000;
    for (int i = 0; i < kFrames; ++i) {
        stream.clear();
        const int kind = static_cast<int>(rng() % 3);
        if (kind == 0) {
            const std::size_t n = 1 + rng() % (rng() % 8 == 0 ? 1500 : 40);
            for (std::size_t j = 0; j < n; ++j) stream.push_back(static_cast<uint8_t>(1 + rng() % 255));
            stream.push_back(0);
        } else {
            body.resize(rng() % 2 == 0 ? rng() % 24 : rng() % (kMaxBody + 1));
            for (auto& b : body) b = static_cast<uint8_t>(rng());
            // Random request types, but never a SetParams that could be valid by chance.
            uint8_t type = static_cast<uint8_t>(rng() % 3 == 0 ? rng() : 1 + rng() % 14);
            if (type == static_cast<uint8_t>(MsgType::kSetParams) && !body.empty() && rng() % 2 == 0) body[0] = 0x77;
            // Requests whose valid form is this short would change the state:
            // keep them malformed (the valid ones are tested above).
            const MsgType mt = static_cast<MsgType>(type);
            if (mt == MsgType::kArm || mt == MsgType::kDisarm || mt == MsgType::kClearTrip || mt == MsgType::kStartWave ||
                mt == MsgType::kStopWave || mt == MsgType::kRecorderArm || mt == MsgType::kRecorderStop ||
                mt == MsgType::kStreamStart || mt == MsgType::kStreamStop || mt == MsgType::kStopExcitation) {
                if (body.size() < 3) body.resize(3, 0xEE);
            }
            if (mt == MsgType::kStartExcitation && body.size() == 45) body.push_back(0xEE);
            const std::size_t n = encode_frame(type, static_cast<uint8_t>(rng() % 16 == 0 ? kProtocolVersion + 1 : kProtocolVersion), static_cast<uint16_t>(i), body, f);
            stream.assign(f.begin(), f.begin() + static_cast<long>(n));
            if (kind == 2) {
                // Damage: flip, drop or insert a byte (not the delimiter).
                const std::size_t at = rng() % (n - 1);
                const int how = static_cast<int>(rng() % 3);
                if (how == 0) stream[at] = static_cast<uint8_t>(stream[at] ^ (1u << (rng() % 8)));
                else if (how == 1) stream.erase(stream.begin() + static_cast<long>(at));
                else stream.insert(stream.begin() + static_cast<long>(at), static_cast<uint8_t>(1 + rng() % 255));
                // Keep exactly one frame per chunk: no zero inside, one at the end.
                if (stream.back() != 0) stream.push_back(0);
                for (std::size_t j = 0; j + 1 < stream.size(); ++j)
                    if (stream[j] == 0) stream[j] = 0x5A;
            } else {
                ++good_frames;
            }
        }
        ++chunks;
        // Feed in random pieces.
        std::size_t at = 0;
        r_.replies.clear();
        while (at < stream.size()) {
            const std::size_t n = std::min<std::size_t>(1 + rng() % 64, stream.size() - at);
            r_.device->receive(std::span<const uint8_t>(stream).subspan(at, n), r_.sink());
            at += n;
        }
        replies += r_.replies.size();
        for (const Reply& r : r_.replies) {
            ASSERT_NE(r.type(), MsgType::kAck) << "a random request was accepted: " << int(r.header.type);
        }
        if (i % 64 == 0) r_.tick();
    }
    const LinkCounters& c = r_.device->counters();
    // Every chunk is accounted for: delivered, or dropped by framing for a reason.
    const uint32_t framing_drops = (c.bad_cobs - c0.bad_cobs) + (c.bad_crc - c0.bad_crc) + (c.oversize - c0.oversize) +
                                   (c.truncated - c0.truncated);
    const uint32_t delivered = c.frames_ok - c0.frames_ok;
    // Every delivered frame got exactly one reply (a truncated body counts
    // as truncated and is replied to, hence <= on the framing side).
    EXPECT_EQ(delivered, replies);
    EXPECT_GE(delivered, good_frames);
    EXPECT_LE(delivered + framing_drops, chunks + (c.truncated - c0.truncated));
    EXPECT_GE(delivered + framing_drops, chunks);
    EXPECT_GT(c.bad_crc - c0.bad_crc, 1000u);
    EXPECT_GT(c.oversize - c0.oversize, 100u);
    EXPECT_GT(c.unknown_type - c0.unknown_type, 1000u);
    EXPECT_GT(c.bad_version - c0.bad_version, 1000u);

    // Still alive, and the state is what it was.
    EXPECT_EQ(r_.request(Hello{}).type(), MsgType::kHelloReply);
    EXPECT_EQ(this->snapshot(), before);
}

// ---- StartWave flags ---------------------------------------------------------

TEST(LinkStartWave, TheBodyIsAxisThenFlags) {
    for (const uint8_t flags : {uint8_t{0}, uint8_t{1}, uint8_t{6}, uint8_t{7}, uint8_t{0x80}}) {
        std::array<uint8_t, 4> buf{};
        Writer w(buf);
        StartWave sent{flags};
        sent.axis = 2;
        sent.write(w);
        ASSERT_EQ(w.size(), 2u);
        EXPECT_EQ(buf[0], 2u);
        EXPECT_EQ(buf[1], flags);
        StartWave back{0x55};
        EXPECT_EQ(decode_body(std::span<const uint8_t>(buf.data(), w.size()), back), DecodeResult::kOk);
        EXPECT_EQ(back, sent);
    }
    // One layout: no body, one byte or three bytes do not match it.
    StartWave m;
    EXPECT_EQ(decode_body(std::span<const uint8_t>(), m), DecodeResult::kTruncated);
    const std::array<uint8_t, 1> one{0};
    EXPECT_EQ(decode_body(std::span<const uint8_t>(one), m), DecodeResult::kTruncated);
    const std::array<uint8_t, 3> three{0, 1, 0};
    EXPECT_EQ(decode_body(std::span<const uint8_t>(three), m), DecodeResult::kTooLong);
}

namespace {

// A stand-in for the firmware's tick mask and emulated stage: records the
// order of calls so the test can see the restart inside the masked section.
struct HookLog {
    static inline std::vector<std::string> calls;
    static inline bool restart_ok = true;
    static void mask(bool m) { calls.push_back(m ? "mask" : "unmask"); }
    static bool restart() {
        calls.push_back("restart");
        return restart_ok;
    }
};

}  // namespace

template <class T>
class LinkStartWaveFlags : public LinkDevice<T> {
protected:
    void SetUp() override {
        HookLog::calls.clear();
        HookLog::restart_ok = true;
        DeviceHooks hooks;
        hooks.mask_tick = &HookLog::mask;
        hooks.restart_stage = &HookLog::restart;
        this->rig.device = std::make_unique<Device<T>>(*this->rig.pipeline, DeviceInfo{"test-board", "1.2.3", "SN0001"}, hooks);
    }
    TrajectoryParams wave() const {
        TrajectoryParams tp;
        tp.waveform = Waveform::kSine;
        tp.amplitude_um = 5.0f;
        tp.offset_um = 1.0f;
        tp.frequency_Hz = 250.0f;
        return tp;
    }
    RecorderParams recorder() const {
        RecorderParams rp;
        rp.channel_count = 4;
        rp.channels = {0, 1, 2, 3};
        rp.decimation = 1;
        rp.mode = RecordMode::kContinuous;
        return rp;
    }
    // Nothing started: the refused request left the loop as it was.
    void expect_nothing_started() {
        EXPECT_FALSE(this->rig.pipeline->wave_running());
        EXPECT_FALSE(this->rig.pipeline->armed());
        EXPECT_EQ(this->rig.pipeline->recorder().state(), RecorderState::kIdle);
    }
};
TYPED_TEST_SUITE(LinkStartWaveFlags, SampleTypes);

// The first recorded frame is the wave's tick 0 with the loop freshly armed:
// frame for frame (bit for bit) what a fresh pipeline gives when the wave is
// started and the loop armed before its first tick -- host/sim's start. The
// rig's stage reads y = 0 every tick, the same input for both.
TYPED_TEST(LinkStartWaveFlags, AllFlagsTakeEffectAtTheSameTick) {
    using T = TypeParam;
    auto& r_ = this->rig;
    this->configure_reference();
    ASSERT_EQ(r_.set(this->wave()).type(), MsgType::kAck);
    ASSERT_EQ(r_.set(this->recorder()).type(), MsgType::kAck);
    r_.tick(37);  // disarmed ticks before: the output has sat at 0 V
    HookLog::calls.clear();
    const uint32_t start_tick = r_.pipeline->tick_count();
    ASSERT_EQ(r_.request(StartWave{StartWave::kArmLoop | StartWave::kArmRecorder | StartWave::kRestartStage}).type(),
              MsgType::kAck);
    EXPECT_EQ(HookLog::calls, (std::vector<std::string>{"mask", "restart", "unmask"}));
    EXPECT_TRUE(r_.pipeline->armed());
    EXPECT_TRUE(r_.pipeline->wave_running());

    constexpr int kTicks = 700;
    r_.tick(kTicks);
    std::vector<LogBlock> blocks;
    r_.replies.clear();
    while (r_.device->poll_log(r_.sink())) {}
    for (const Reply& rep : r_.replies) blocks.push_back(rep.template as<LogBlock>());
    ASSERT_FALSE(blocks.empty());
    EXPECT_EQ(blocks[0].first_tick, start_tick);

    // Reference: fresh pipeline, start_wave + arm, then tick 0.
    auto ref = std::make_unique<typename Device<T>::PipelineType>(reference::setup());
    ASSERT_TRUE(ref->stage(reference::params(true, true, false)).ok());
    TrajectoryConfig c;
    const TrajectoryParams tp = this->wave();
    c.waveform = tp.waveform;
    c.amplitude_um = tp.amplitude_um;
    c.offset_um = tp.offset_um;
    c.frequency_Hz = tp.frequency_Hz;
    c.sample_rate_Hz = reference::setup().rate_Hz;
    c.start_phase_cycles = tp.start_phase_cycles;
    c.return_fraction = tp.return_fraction;
    c.duty = tp.duty;
    ASSERT_TRUE(ref->start_wave(c).ok());
    ref->arm();
    std::size_t k = 0;
    for (const LogBlock& b : blocks) {
        EXPECT_EQ(b.first_tick, start_tick + k);
        for (std::size_t f = 0; f < b.frame_count; ++f, ++k) {
            ref->tick(sample_zero<T>());
            const auto& s = ref->last();
            const std::array<T, 4> want{s.r, s.y, s.e, s.u};
            for (std::size_t ch = 0; ch < 4; ++ch) {
                T v;
                if constexpr (std::is_same_v<T, float>) v = std::bit_cast<float>(b.samples[f * 4 + ch]);
                else v = Q31::from_raw(static_cast<int32_t>(b.samples[f * 4 + ch]));
                ASSERT_EQ(v, want[ch]) << "frame " << k << " channel " << ch;
            }
        }
    }
    // All but the last partial block were sent (700 frames, 30 per block).
    EXPECT_GE(k, static_cast<std::size_t>(kTicks) - Device<T>::kFramesPerBlock);
    // The wave moved the reference: the comparison was not of zeros.
    EXPECT_NE(ref->last().u, sample_zero<T>());
}

// The wave's approach starts where the stage is: after a restart at 0 (the
// restarted stage's next reading), without one at the stage's last reading.
TYPED_TEST(LinkStartWaveFlags, TheApproachStartsWhereTheRestartedStageIs) {
    using T = TypeParam;
    auto& r_ = this->rig;
    this->configure_reference();
    ASSERT_EQ(r_.set(this->wave()).type(), MsgType::kAck);
    const SignalScale pos = reference::setup().position;
    const TrajectoryParams tp = this->wave();
    TrajectoryGenerator<T> gen(pos);
    ASSERT_TRUE(gen.configure(params::trajectory_config(tp, reference::setup().rate_Hz)).ok());
    for (const bool restart : {false, true}) {
        r_.pipeline->stop_wave();
        r_.pipeline->disarm();
        for (int k = 0; k < 3; ++k) r_.pipeline->tick(pos.to_sample<T>(3.0f));  // the stage reads 3 um
        ASSERT_FALSE(r_.pipeline->wave_running());
        const uint8_t flags = StartWave::kArmLoop | (restart ? StartWave::kRestartStage : 0);
        ASSERT_EQ(r_.request(StartWave{flags}).type(), MsgType::kAck);
        Approach<T> ref(pos, reference::setup().rate_Hz);
        ASSERT_TRUE(ref.begin(restart ? sample_zero<T>() : pos.to_sample<T>(3.0f), gen.start_value()));
        for (int k = 0; k < 50; ++k) {
            r_.pipeline->tick(sample_zero<T>());
            ASSERT_EQ(r_.pipeline->last().r, ref.step()) << (restart ? "restarted" : "not restarted") << ", tick " << k;
        }
    }
}

TYPED_TEST(LinkStartWaveFlags, UnknownBitsAreMalformed) {
    auto& r_ = this->rig;
    this->configure_reference();
    ASSERT_EQ(r_.set(this->wave()).type(), MsgType::kAck);
    ASSERT_EQ(r_.set(this->recorder()).type(), MsgType::kAck);
    const uint32_t bad0 = r_.device->counters().bad_value;
    for (const uint8_t flags : {uint8_t{0x10}, uint8_t{0x81}, uint8_t{0xFF}}) {
        this->expect_error(r_.request(StartWave{flags}), ErrorCode::kMalformed, nullptr, "flags");
        this->expect_nothing_started();
    }
    EXPECT_EQ(r_.device->counters().bad_value, bad0 + 3);
    EXPECT_TRUE(HookLog::calls.empty() || std::find(HookLog::calls.begin(), HookLog::calls.end(), "restart") ==
                                              HookLog::calls.end());
}

TYPED_TEST(LinkStartWaveFlags, RefusalsStartNothing) {
    auto& r_ = this->rig;
    this->configure_reference();
    ASSERT_EQ(r_.set(this->wave()).type(), MsgType::kAck);
    // Recorder flag before a recorder configuration.
    this->expect_error(r_.request(StartWave{StartWave::kArmRecorder | StartWave::kArmLoop}), ErrorCode::kNotConfigured,
                       "recorder", "channels");
    this->expect_nothing_started();
    ASSERT_EQ(r_.set(this->recorder()).type(), MsgType::kAck);
    // The stage could not restart: nothing else happens either.
    HookLog::restart_ok = false;
    this->expect_error(r_.request(StartWave{StartWave::kRestartStage | StartWave::kArmLoop}), ErrorCode::kUnsupported,
                       nullptr, "flags");
    this->expect_nothing_started();
    HookLog::restart_ok = true;
    // Arm flag while armed: the controller would not restart from rest.
    ASSERT_EQ(r_.request(Arm{}).type(), MsgType::kAck);
    this->expect_error(r_.request(StartWave{StartWave::kArmLoop}), ErrorCode::kArmed, nullptr, "flags");
    EXPECT_FALSE(r_.pipeline->wave_running());
    // Without the arm flag the wave starts on the armed loop.
    EXPECT_EQ(r_.request(StartWave{StartWave::kArmRecorder}).type(), MsgType::kAck);
    EXPECT_TRUE(r_.pipeline->wave_running());
    EXPECT_EQ(r_.pipeline->recorder().state(), RecorderState::kArmed);
}

// A StartExcitation whose point byte (offset 3, after axis, flags, signal) is 7: beyond the enumeration.
struct StartExcitationBadPoint {
    static constexpr MsgType kType = MsgType::kStartExcitation;
    StartExcitation m;
    void write(Writer& w) const {
        std::array<uint8_t, kMaxBody> body{};
        Writer inner(body);
        m.write(inner);
        body[3] = 7;
        for (std::size_t i = 0; i < inner.size(); ++i) w.u8(body[i]);
    }
};

// StartExcitation: refused requests start nothing (disarmed without the arm
// flag, a malformed point, a command beyond the limits, a second one), an
// accepted one arms the loop and the recorder at one tick, d is recorded as
// signal 7, the status counts its ticks, and StopExcitation ends it.
TYPED_TEST(LinkStartWaveFlags, StartExcitationChecksThenRunsAndStops) {
    using T = TypeParam;
    auto& r_ = this->rig;
    this->configure_reference();
    // Open loop: no feedforward, no feedback (the reference limits stay).
    ASSERT_EQ(r_.set(FeedforwardParams{}).type(), MsgType::kAck);
    r_.tick();
    ASSERT_EQ(r_.set(FeedbackParams{}).type(), MsgType::kAck);
    RecorderParams rp = this->recorder();
    rp.channels = {signal_index(SignalId::kR), signal_index(SignalId::kY), signal_index(SignalId::kU),
                   signal_index(SignalId::kD)};
    ASSERT_EQ(r_.set(rp).type(), MsgType::kAck);
    r_.tick();
    const LimitsConfig lim = r_.pipeline->params().limits;
    StartExcitation m;
    m.config.signal = ExcitationSignal::kTriangle;
    m.config.period_samples = 100;
    m.config.periods = 2;
    m.config.offset = lim.u_min_V;
    m.config.amplitude = lim.u_max_V - lim.u_min_V;  // the whole range: allowed
    this->expect_error(r_.request(m), ErrorCode::kNotConfigured, nullptr, "flags");  // disarmed, no arm flag
    StartExcitation beyond = m;
    beyond.flags = StartExcitation::kArmLoop;
    beyond.config.amplitude *= 1.01f;
    this->expect_error(r_.request(beyond), ErrorCode::kInvalidParam, "excitation", "amplitude");
    this->expect_nothing_started();
    EXPECT_FALSE(r_.pipeline->excitation_running());
    // A point value beyond the enumeration is malformed, counted.
    const uint32_t bad_before = r_.device->counters().bad_value;
    this->expect_error(r_.request(StartExcitationBadPoint{m}), ErrorCode::kMalformed, nullptr, "body");
    EXPECT_EQ(r_.device->counters().bad_value, bad_before + 1);

    m.flags = StartExcitation::kArmLoop | StartExcitation::kArmRecorder | StartExcitation::kRestartStage;
    const uint32_t start_tick = r_.pipeline->tick_count();
    ASSERT_EQ(r_.request(m).type(), MsgType::kAck);
    EXPECT_TRUE(r_.pipeline->armed());
    EXPECT_TRUE(r_.pipeline->excitation_running());
    this->expect_error(r_.request(m), ErrorCode::kBusy, "excitation", "signal");
    r_.tick(50);
    StatusReply st = r_.request(GetStatus{}).template as<StatusReply>();
    EXPECT_TRUE(st.excitation_running);
    EXPECT_EQ(st.excitation_ticks, 50u);
    // d is recorded: the first frame is the lead-in's first sample, the
    // command in effect (the disarmed 0 V), from which d moves to its
    // offset (lead_in.hpp).
    r_.replies.clear();
    while (r_.device->poll_log(r_.sink())) {}
    ASSERT_FALSE(r_.replies.empty());
    const LogBlock b = r_.replies[0].template as<LogBlock>();
    EXPECT_EQ(b.first_tick, start_tick);
    EXPECT_EQ(b.channels[3], signal_index(SignalId::kD));
    T d0;
    if constexpr (std::is_same_v<T, float>) d0 = std::bit_cast<float>(b.samples[3]);
    else d0 = Q31::from_raw(static_cast<int32_t>(b.samples[3]));
    EXPECT_NEAR(r_.pipeline->setup().voltage.to_physical(d0), 0.0, 1e-6);
    EXPECT_GT(r_.pipeline->excitation_lead_in_ticks(), 1u);
    EXPECT_EQ(r_.request(StopExcitation{}).type(), MsgType::kAck);
    r_.tick();
    st = r_.request(GetStatus{}).template as<StatusReply>();
    EXPECT_FALSE(st.excitation_running);
    EXPECT_EQ(st.excitation_ticks, 51u);
}

// A StartExcitation whose sizes wrap 32-bit arithmetic is refused at once
// and the device stays responsive: a multisine's 2 k2 < N check at k2 near
// 2^31 (2 k2 wraps below N), and a PRBS period (2^n - 1) h beyond 2^32 - 1.
TYPED_TEST(LinkStartWaveFlags, StartExcitationSizesThatWrapAreRefused) {
    auto& r_ = this->rig;
    this->configure_reference();
    const LimitsConfig lim = r_.pipeline->params().limits;
    StartExcitation m;
    m.flags = StartExcitation::kArmLoop;
    m.config.signal = ExcitationSignal::kMultisine;
    m.config.offset = 0.5f * (lim.u_min_V + lim.u_max_V);
    m.config.amplitude = 0.1f * (lim.u_max_V - lim.u_min_V);
    m.config.first_bin = 1;
    for (const auto& [n, k2] : {std::pair{1000u, 0x80000000u}, std::pair{1000u, 0x80000000u + 300u},
                                std::pair{999u, 0x80000000u + 499u}, std::pair{1024u, 0xffffffffu},
                                std::pair{4u, 0x80000001u}}) {
        m.config.period_samples = n;
        m.config.last_bin = k2;
        this->expect_error(r_.request(m), ErrorCode::kInvalidParam, "excitation", "last_bin");
    }
    m.config.signal = ExcitationSignal::kPrbs;
    m.config.prbs_order = 24;
    m.config.prbs_hold = 257;  // (2^24 - 1) 257 > 2^32 - 1
    this->expect_error(r_.request(m), ErrorCode::kInvalidParam, "excitation", "prbs_hold");
    this->expect_nothing_started();
    EXPECT_EQ(r_.request(GetStatus{}).type(), MsgType::kStatusReply);
}

TYPED_TEST(LinkDevice, RestartFlagWithoutAStageIsUnsupported) {
    auto& r_ = this->rig;  // default hooks: no restart_stage
    this->configure_reference();
    TrajectoryParams tp;
    tp.amplitude_um = 2.0f;
    ASSERT_EQ(r_.set(tp).type(), MsgType::kAck);
    this->expect_error(r_.request(StartWave{StartWave::kRestartStage}), ErrorCode::kUnsupported, nullptr, "flags");
    EXPECT_FALSE(r_.pipeline->wave_running());
    // The other flags work without hooks.
    EXPECT_EQ(r_.request(StartWave{StartWave::kArmLoop}).type(), MsgType::kAck);
    EXPECT_TRUE(r_.pipeline->armed());
    EXPECT_TRUE(r_.pipeline->wave_running());
}

// ---- client loss ---------------------------------------------------------------

namespace {

template <class T>
class LinkClientLoss : public LinkDevice<T> {
protected:
    // The main loop's regular call, which watches the client.
    void main_loop() {
        this->rig.device->poll_log([](std::span<const uint8_t>) {});
    }
    // n ticks of silence, the main loop running after each.
    void silence(int n) {
        for (int i = 0; i < n; ++i) {
            this->rig.tick();
            main_loop();
        }
    }
    int timeout_ticks(float s) const { return static_cast<int>(static_cast<double>(s) * reference::setup().rate_Hz + 0.5); }
    void start_triangle(uint8_t flags) {
        TrajectoryParams tp;
        tp.waveform = Waveform::kTriangle;
        tp.amplitude_um = 12.0f;
        tp.frequency_Hz = 10.0f;
        ASSERT_EQ(this->rig.set(tp).type(), MsgType::kAck);
        ASSERT_EQ(this->rig.request(StartWave{flags}).type(), MsgType::kAck);
    }
};
TYPED_TEST_SUITE(LinkClientLoss, SampleTypes);

TYPED_TEST(LinkClientLoss, AnAbandonedStreamIsClosedAndTheSetpointHolds) {
    auto& r_ = this->rig;
    this->configure_reference();
    ASSERT_EQ(r_.set(LinkParams{0.01f, params::ClientLossAction::kHold}).type(), MsgType::kAck);
    EXPECT_EQ(r_.request(StreamStart{0}).type(), MsgType::kSetpointAck);
    SetpointBlock b;
    b.count = 10;
    for (int i = 0; i < 10; ++i) b.setpoint_um[static_cast<unsigned>(i)] = 1.0f + 0.1f * static_cast<float>(i);
    ASSERT_EQ(r_.request(b).type(), MsgType::kSetpointAck);
    EXPECT_EQ(r_.request(Arm{}).type(), MsgType::kAck);
    // The client dies: the FIFO runs dry after 10 ticks (underruns, never
    // silent); a status request from elsewhere does not feed the stream; one
    // timeout after the last block the stream is closed, the loop stays armed.
    this->silence(this->timeout_ticks(0.01f) - 2);
    EXPECT_EQ(r_.request(GetStatus{}).type(), MsgType::kStatusReply);
    EXPECT_TRUE(r_.device->streaming());
    this->silence(2);
    EXPECT_FALSE(r_.device->streaming());
    EXPECT_TRUE(r_.pipeline->armed());
    const StatusReply st = r_.request(GetStatus{}).template as<StatusReply>();
    EXPECT_NE(st.faults & fault::kClientLost, 0u);
    EXPECT_NEAR(st.r_um, 1.9f, 1e-3f);  // the last streamed setpoint holds
    // A new client can start a wave at once; the report clears.
    this->start_triangle(0);
    EXPECT_EQ(r_.request(GetStatus{}).template as<StatusReply>().faults & fault::kClientLost, 0u);
}

TYPED_TEST(LinkClientLoss, AStreamLeftPrimingIsClosedToo) {
    // Killed before the prefill was reached: nothing consumed, nothing
    // empty, but nothing sent either.
    auto& r_ = this->rig;
    this->configure_reference();
    ASSERT_EQ(r_.set(LinkParams{0.01f, params::ClientLossAction::kHold}).type(), MsgType::kAck);
    EXPECT_EQ(r_.request(StreamStart{1000}).type(), MsgType::kSetpointAck);
    SetpointBlock b;
    b.count = 100;
    ASSERT_EQ(r_.request(b).type(), MsgType::kSetpointAck);
    this->silence(this->timeout_ticks(0.01f) + 1);
    EXPECT_FALSE(r_.device->streaming());
    // A drained stream is the client's own end: never cut short.
    EXPECT_EQ(r_.request(StreamStart{0}).type(), MsgType::kSetpointAck);
    ASSERT_EQ(r_.request(b).type(), MsgType::kSetpointAck);
    ASSERT_EQ(r_.request(StreamStop{true}).type(), MsgType::kAck);
    this->silence(120);  // the 100 buffered setpoints, then the drained end
    EXPECT_FALSE(r_.device->streaming());
    EXPECT_EQ(r_.request(GetStatus{}).template as<StatusReply>().faults & fault::kClientLost, 0u);
}

TYPED_TEST(LinkClientLoss, AWaveStopsWhenItsClientGoesSilentAndDisarmsIfAsked) {
    auto& r_ = this->rig;
    this->configure_reference();
    ASSERT_EQ(r_.set(LinkParams{0.02f, params::ClientLossAction::kDisarm}).type(), MsgType::kAck);
    this->start_triangle(StartWave::kArmLoop);
    // A client that keeps talking keeps its wave.
    for (int k = 0; k < 5; ++k) {
        this->silence(this->timeout_ticks(0.02f) / 2);
        EXPECT_EQ(r_.request(GetStatus{}).type(), MsgType::kStatusReply);
    }
    EXPECT_TRUE(r_.pipeline->wave_running());
    this->silence(this->timeout_ticks(0.02f) + 2);
    EXPECT_FALSE(r_.pipeline->wave_running());
    EXPECT_FALSE(r_.pipeline->armed());
    EXPECT_NE(r_.request(GetStatus{}).template as<StatusReply>().faults & fault::kClientLost, 0u);
}

TYPED_TEST(LinkClientLoss, ADetachedWaveRunsOnAndZeroMeansNever) {
    auto& r_ = this->rig;
    this->configure_reference();
    ASSERT_EQ(r_.set(LinkParams{0.01f, params::ClientLossAction::kHold}).type(), MsgType::kAck);
    this->start_triangle(StartWave::kDetached);
    this->silence(this->timeout_ticks(0.01f) * 3);
    EXPECT_TRUE(r_.pipeline->wave_running());
    EXPECT_EQ(r_.request(StopWave{}).type(), MsgType::kAck);
    r_.tick();
    ASSERT_EQ(r_.set(LinkParams{0.0f, params::ClientLossAction::kHold}).type(), MsgType::kAck);
    this->start_triangle(0);
    this->silence(this->timeout_ticks(0.05f));
    EXPECT_TRUE(r_.pipeline->wave_running());
}

// A Hello opens another client's session: a bound excitation or wave is
// lost at once (a later client that keeps the link alive must not keep
// alive what a killed one started); a detached one, a draining stream, and
// anything with the watchdog off (timeout 0) run on.
TYPED_TEST(LinkClientLoss, AHelloEndsWhatThePreviousSessionStarted) {
    auto& r_ = this->rig;
    this->configure_reference();
    ASSERT_EQ(r_.set(LinkParams{5.0f, params::ClientLossAction::kDisarm}).type(), MsgType::kAck);
    r_.tick();
    const LimitsConfig lim = r_.pipeline->params().limits;
    StartExcitation m;
    m.flags = StartExcitation::kArmLoop;
    m.config.signal = ExcitationSignal::kTriangle;
    m.config.period_samples = 200;
    m.config.offset = lim.u_min_V;
    m.config.amplitude = 0.5f * (lim.u_max_V - lim.u_min_V);
    ASSERT_EQ(r_.request(m).type(), MsgType::kAck);
    this->silence(10);
    EXPECT_EQ(r_.request(GetStatus{}).type(), MsgType::kStatusReply);  // its own client: runs on
    this->silence(1);
    EXPECT_TRUE(r_.pipeline->excitation_running());
    EXPECT_EQ(r_.request(Hello{}).type(), MsgType::kHelloReply);
    r_.tick();
    EXPECT_FALSE(r_.pipeline->excitation_running());
    EXPECT_FALSE(r_.pipeline->armed());
    EXPECT_NE(r_.request(GetStatus{}).template as<StatusReply>().faults & fault::kClientLost, 0u);

    this->start_triangle(StartWave::kDetached);
    EXPECT_EQ(r_.request(Hello{}).type(), MsgType::kHelloReply);
    this->silence(3);
    EXPECT_TRUE(r_.pipeline->wave_running());
    EXPECT_EQ(r_.request(StopWave{}).type(), MsgType::kAck);
    r_.tick();
    ASSERT_EQ(r_.set(LinkParams{0.0f, params::ClientLossAction::kHold}).type(), MsgType::kAck);
    this->start_triangle(0);
    EXPECT_EQ(r_.request(Hello{}).type(), MsgType::kHelloReply);
    this->silence(3);
    EXPECT_TRUE(r_.pipeline->wave_running());
}

// A timeout above 0 but below half a tick is at least one tick, never
// "never": the smallest float, and 0.4 of a tick at the loop rate.
TYPED_TEST(LinkClientLoss, ATimeoutBelowOneTickIsOneTick) {
    auto& r_ = this->rig;
    this->configure_reference();
    const float rate = reference::setup().rate_Hz;
    for (const float s : {std::numeric_limits<float>::denorm_min(), 0.4f / rate, 0.49f / rate, 1.0e-30f}) {
        ASSERT_EQ(r_.set(LinkParams{s, params::ClientLossAction::kHold}).type(), MsgType::kAck) << s;
        this->start_triangle(0);
        this->silence(2);
        EXPECT_FALSE(r_.pipeline->wave_running()) << s;
        EXPECT_NE(r_.request(GetStatus{}).template as<StatusReply>().faults & fault::kClientLost, 0u) << s;
    }
}

TYPED_TEST(LinkClientLoss, TheLinkGroupIsCheckedAndReadBack) {
    auto& r_ = this->rig;
    const LinkParams defaults = r_.template get<LinkParams>(ParamGroup::kLink);
    EXPECT_EQ(defaults.client_timeout_s, 1.0f);
    this->expect_error(r_.set(LinkParams{-1.0f, params::ClientLossAction::kHold}), ErrorCode::kInvalidParam, "link",
                       "client_timeout_s");
    this->expect_error(r_.set(LinkParams{1.0f, static_cast<params::ClientLossAction>(2)}), ErrorCode::kInvalidParam,
                       "link", "on_client_loss");
    EXPECT_EQ(r_.template get<LinkParams>(ParamGroup::kLink), defaults);
    const LinkParams l{2.5f, params::ClientLossAction::kDisarm};
    EXPECT_EQ(r_.set(l).type(), MsgType::kAck);
    EXPECT_EQ(r_.template get<LinkParams>(ParamGroup::kLink), l);
}

}  // namespace
