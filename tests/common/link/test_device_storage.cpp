// Save, Load and Forget on the device-side dispatcher with the in-memory
// storage, and the load at boot: a saved set comes back exactly (every
// group GetParams reports), a forgotten one is gone, a stored set that is
// corrupt, from another firmware or rejected by validation changes nothing
// and says why, and all three requests are refused while armed or without
// storage.
#include <gtest/gtest.h>

#include <cstring>
#include <limits>
#include <vector>

#include "piezoloop/storage/memory_storage.hpp"
#include "test_link_client.hpp"

using namespace link_test;
using piezoloop::storage::MemoryStorage;

namespace {

template <class T>
class DeviceStorage : public ::testing::Test {
protected:
    MemoryStorage mem;

    DeviceHooks hooks() {
        DeviceHooks h;
        h.storage = &mem;
        return h;
    }

    // Limits, the reference controller, a trajectory, a recorder and a link
    // group: every group GetParams reports, none at its default.
    static void commission(Rig<T>& rig) {
        const PipelineParams p = reference::params(true, true, false);
        ASSERT_EQ(rig.set(LimitsParams{p.limits}).type(), MsgType::kAck);
        rig.tick();
        ASSERT_EQ(rig.set(FeedforwardParams{p.feedforward, p.pi, p.dahl}).type(), MsgType::kAck);
        rig.tick();
        ASSERT_EQ(rig.set(FeedbackParams{p.feedback, p.sos_count, p.sos, p.pid}).type(), MsgType::kAck);
        rig.tick();
        TrajectoryParams t;
        t.waveform = Waveform::kTriangle;
        t.amplitude_um = 4.0f;
        t.frequency_Hz = 25.0f;
        ASSERT_EQ(rig.set(t).type(), MsgType::kAck);
        RecorderParams r;
        r.channel_count = 4;
        r.channels = {0, 1, 2, 3};
        r.decimation = 3;
        r.mode = RecordMode::kContinuous;
        ASSERT_EQ(rig.set(r).type(), MsgType::kAck);
        LinkParams l;
        l.client_timeout_s = 0.25f;
        l.on_client_loss = params::ClientLossAction::kDisarm;
        ASSERT_EQ(rig.set(l).type(), MsgType::kAck);
    }

    // Every group's GetParams reply, as bytes.
    static std::vector<std::vector<uint8_t>> groups(Rig<T>& rig) {
        std::vector<std::vector<uint8_t>> s;
        for (int g = 1; g <= params::kGroupCount; ++g) {
            const Reply r = rig.request(GetParams{static_cast<ParamGroup>(g)});
            EXPECT_EQ(r.type(), MsgType::kParamsReply);
            s.push_back(r.body);
        }
        return s;
    }

    static ErrorReply expect_error(const Reply& r, ErrorCode code, const char* group, const char* field) {
        EXPECT_EQ(r.type(), MsgType::kError);
        if (r.type() != MsgType::kError) return {};
        const ErrorReply e = r.template as<ErrorReply>();
        EXPECT_EQ(e.code, code) << error_code_name(e.code) << ": " << e.message.data();
        EXPECT_STREQ(e.group.data(), group);
        EXPECT_STREQ(e.field.data(), field);
        EXPECT_GT(std::strlen(e.message.data()), 0u);
        return e;
    }
};

using SampleTypes = ::testing::Types<float, Q31>;
TYPED_TEST_SUITE(DeviceStorage, SampleTypes);

}  // namespace

TYPED_TEST(DeviceStorage, HelloAdvertisesStorageOnlyWithABackend) {
    Rig<TypeParam> with(this->hooks());
    EXPECT_NE(with.request(Hello{}).template as<HelloReply>().capabilities & cap::kStorage, 0u);
    Rig<TypeParam> without;
    EXPECT_EQ(without.request(Hello{}).template as<HelloReply>().capabilities & cap::kStorage, 0u);
}

TYPED_TEST(DeviceStorage, WithoutStorageEveryRequestIsUnsupported) {
    Rig<TypeParam> rig;
    EXPECT_EQ(rig.device->boot_from_storage(), StorageState::kAbsent);
    for (const Reply& r : {rig.request(Save{}), rig.request(Load{}), rig.request(Forget{})})
        this->expect_error(r, ErrorCode::kUnsupported, "", "storage");
    EXPECT_EQ(rig.request(GetStatus{}).template as<StatusReply>().storage, StorageState::kAbsent);
}

TYPED_TEST(DeviceStorage, SaveThenLoadRestoresEveryGroup) {
    Rig<TypeParam> rig(this->hooks());
    this->commission(rig);
    const auto saved = this->groups(rig);
    ASSERT_EQ(rig.request(Save{}).type(), MsgType::kAck);
    EXPECT_EQ(this->mem.writes(), 1);

    // Change every group, then load: all of them are back.
    ASSERT_EQ(rig.set(LimitsParams{LimitsConfig{-1.0f, 1.0f, 1000.0f, 0.0f}}).type(), MsgType::kAck);
    rig.tick();
    ASSERT_EQ(rig.set(FeedbackParams{}).type(), MsgType::kAck);
    rig.tick();
    ASSERT_EQ(rig.set(TrajectoryParams{}).type(), MsgType::kAck);
    ASSERT_EQ(rig.set(LinkParams{}).type(), MsgType::kAck);
    ASSERT_NE(this->groups(rig), saved);
    ASSERT_EQ(rig.request(Load{}).type(), MsgType::kAck);
    EXPECT_EQ(this->groups(rig), saved);  // the staged set, before its swap
    rig.tick();
    EXPECT_EQ(this->groups(rig), saved);
    EXPECT_FALSE(rig.request(GetStatus{}).template as<StatusReply>().armed);
}

TYPED_TEST(DeviceStorage, SavedSetIsAppliedAtBootDisarmed) {
    {
        Rig<TypeParam> first(this->hooks());
        this->commission(first);
        ASSERT_EQ(first.request(Save{}).type(), MsgType::kAck);
    }
    Rig<TypeParam> first_again(this->hooks());
    this->commission(first_again);
    const auto saved = this->groups(first_again);

    Rig<TypeParam> rebooted(this->hooks());  // same storage, fresh pipeline
    EXPECT_EQ(rebooted.device->boot_from_storage(), StorageState::kApplied);
    rebooted.tick();
    EXPECT_EQ(this->groups(rebooted), saved);
    const StatusReply st = rebooted.request(GetStatus{}).template as<StatusReply>();
    EXPECT_EQ(st.storage, StorageState::kApplied);
    EXPECT_STREQ(st.storage_field.data(), "");
    EXPECT_FALSE(st.armed);
    // The limits came back configured: the loop can be armed.
    EXPECT_EQ(rebooted.request(Arm{}).type(), MsgType::kAck);
}

TYPED_TEST(DeviceStorage, UnsetTrajectoryAndRecorderStayUnset) {
    Rig<TypeParam> rig(this->hooks());
    const PipelineParams p = reference::params(true, true, false);
    ASSERT_EQ(rig.set(LimitsParams{p.limits}).type(), MsgType::kAck);
    rig.tick();
    ASSERT_EQ(rig.request(Save{}).type(), MsgType::kAck);
    Rig<TypeParam> rebooted(this->hooks());
    EXPECT_EQ(rebooted.device->boot_from_storage(), StorageState::kApplied);
    rebooted.tick();
    this->expect_error(rebooted.request(StartWave{}), ErrorCode::kNotConfigured, "trajectory", "waveform");
    this->expect_error(rebooted.request(RecorderArm{}), ErrorCode::kNotConfigured, "recorder", "channels");
}

TYPED_TEST(DeviceStorage, ForgetThenLoadFailsAndChangesNothing) {
    Rig<TypeParam> rig(this->hooks());
    this->commission(rig);
    ASSERT_EQ(rig.request(Save{}).type(), MsgType::kAck);
    ASSERT_EQ(rig.request(Forget{}).type(), MsgType::kAck);
    const auto before = this->groups(rig);
    this->expect_error(rig.request(Load{}), ErrorCode::kNotConfigured, "storage", "record");
    EXPECT_EQ(this->groups(rig), before);
    Rig<TypeParam> rebooted(this->hooks());
    EXPECT_EQ(rebooted.device->boot_from_storage(), StorageState::kEmpty);
    const StatusReply st = rebooted.request(GetStatus{}).template as<StatusReply>();
    EXPECT_EQ(st.storage, StorageState::kEmpty);
    EXPECT_STREQ(st.storage_field.data(), "");  // nothing to explain
}

TYPED_TEST(DeviceStorage, CorruptSetIsIgnoredAtBootAndSaysWhy) {
    {
        Rig<TypeParam> rig(this->hooks());
        this->commission(rig);
        ASSERT_EQ(rig.request(Save{}).type(), MsgType::kAck);
    }
    this->mem.stored()[this->mem.stored().size() - 3] ^= 0x5A;
    Rig<TypeParam> rebooted(this->hooks());
    Rig<TypeParam> fresh;
    const auto defaults = this->groups(fresh);
    EXPECT_EQ(rebooted.device->boot_from_storage(), StorageState::kCorrupt);
    rebooted.tick();
    EXPECT_EQ(this->groups(rebooted), defaults);
    const StatusReply st = rebooted.request(GetStatus{}).template as<StatusReply>();
    EXPECT_EQ(st.storage, StorageState::kCorrupt);
    EXPECT_STREQ(st.storage_group.data(), "storage");
    EXPECT_STREQ(st.storage_field.data(), "crc");
    EXPECT_GT(std::strlen(st.storage_message.data()), 0u);
    // Load by hand says the same, and changes nothing either.
    this->expect_error(rebooted.request(Load{}), ErrorCode::kStorage, "storage", "crc");
    EXPECT_EQ(this->groups(rebooted), defaults);
    // Nothing can be armed: the limits are not configured.
    EXPECT_EQ(rebooted.request(Arm{}).type(), MsgType::kError);
}

TYPED_TEST(DeviceStorage, SetFromAnotherFirmwareIsIgnored) {
    {
        Rig<TypeParam> rig(this->hooks(), "1.2.3");
        this->commission(rig);
        ASSERT_EQ(rig.request(Save{}).type(), MsgType::kAck);
    }
    Rig<TypeParam> updated(this->hooks(), "1.3.0");
    EXPECT_EQ(updated.device->boot_from_storage(), StorageState::kOtherFirmware);
    const StatusReply st = updated.request(GetStatus{}).template as<StatusReply>();
    EXPECT_STREQ(st.storage_field.data(), "firmware_version");
}

TYPED_TEST(DeviceStorage, SetRejectedByValidationChangesNothing) {
    // A record with a good CRC whose feedforward fails the field check: the
    // limits before it in the record are not applied either.
    Rig<TypeParam> writer(this->hooks());
    storage::StoredParams s;
    link::set_text(s.firmware_version, "1.2.3");
    s.loop_rate_Hz = reference::setup().rate_Hz;
    const PipelineParams p = reference::params(true, true, false);
    storage::StoredAxis& a = s.axes[0];
    a.limits = params::limits_of(p);
    a.feedforward = params::feedforward_of(p);
    a.feedforward.pi.weights[1] = std::numeric_limits<float>::quiet_NaN();
    a.feedback = params::feedback_of(p);
    a.rc = params::rc_of(p);
    const std::size_t n = storage::encode_stored_params(s, this->mem.scratch());
    ASSERT_GT(n, 0u);
    ASSERT_TRUE(this->mem.write(n).ok());

    Rig<TypeParam> fresh;
    const auto defaults = this->groups(fresh);
    Rig<TypeParam> rig(this->hooks());
    EXPECT_EQ(rig.device->boot_from_storage(), StorageState::kRejected);
    rig.tick();
    EXPECT_EQ(this->groups(rig), defaults);
    EXPECT_FALSE(rig.pipeline->limiter().configured());
    const StatusReply st = rig.request(GetStatus{}).template as<StatusReply>();
    EXPECT_EQ(st.storage, StorageState::kRejected);
    EXPECT_STREQ(st.storage_group.data(), "feedforward");
    EXPECT_STREQ(st.storage_field.data(), "pi.weights");
    EXPECT_EQ(st.storage_index, 1);
    const ErrorReply e = this->expect_error(rig.request(Load{}), ErrorCode::kInvalidParam, "feedforward", "pi.weights");
    EXPECT_EQ(e.index, 1);
    EXPECT_EQ(this->groups(rig), defaults);

    // Saved at another loop rate: rejected, naming the rate.
    a.feedforward = params::feedforward_of(p);
    s.loop_rate_Hz = 10000.0f;
    ASSERT_TRUE(this->mem.write(storage::encode_stored_params(s, this->mem.scratch())).ok());
    this->expect_error(rig.request(Load{}), ErrorCode::kInvalidParam, "storage", "loop_rate_Hz");
    EXPECT_EQ(this->groups(rig), defaults);

    // Saved on a board with another axis count: rejected, naming it.
    s.loop_rate_Hz = reference::setup().rate_Hz;
    s.axis_count = 2;
    s.axes[1] = a;
    ASSERT_TRUE(this->mem.write(storage::encode_stored_params(s, this->mem.scratch())).ok());
    this->expect_error(rig.request(Load{}), ErrorCode::kInvalidParam, "storage", "axis_count");
    EXPECT_EQ(this->groups(rig), defaults);
}

// Save checks the set as its load at boot will: a fresh board (limits
// never set) is refused, naming the limits field, and the previous good
// record stays (the next boot applies it).
TYPED_TEST(DeviceStorage, SaveRefusesASetItsBootWouldReject) {
    Rig<TypeParam> good(this->hooks());
    this->commission(good);
    const auto saved = this->groups(good);
    ASSERT_EQ(good.request(Save{}).type(), MsgType::kAck);
    ASSERT_EQ(this->mem.writes(), 1);

    Rig<TypeParam> fresh(this->hooks());
    this->expect_error(fresh.request(Save{}), ErrorCode::kInvalidParam, "limits", "slew_V_per_s");
    EXPECT_EQ(this->mem.writes(), 1);

    Rig<TypeParam> reboot(this->hooks());
    EXPECT_EQ(reboot.device->boot_from_storage(), StorageState::kApplied);
    reboot.tick();
    EXPECT_EQ(this->groups(reboot), saved);
}

TYPED_TEST(DeviceStorage, RefusedWhileArmed) {
    Rig<TypeParam> rig(this->hooks());
    this->commission(rig);
    ASSERT_EQ(rig.request(Save{}).type(), MsgType::kAck);
    ASSERT_EQ(rig.request(Arm{}).type(), MsgType::kAck);
    rig.tick();
    const auto before = this->groups(rig);
    for (const Reply& r : {rig.request(Save{}), rig.request(Load{}), rig.request(Forget{})})
        this->expect_error(r, ErrorCode::kArmed, "", "storage");
    EXPECT_EQ(this->mem.writes(), 1);
    EXPECT_GT(this->mem.stored().size(), 0u);  // not forgotten
    EXPECT_EQ(this->groups(rig), before);
    ASSERT_EQ(rig.request(Disarm{}).type(), MsgType::kAck);
    EXPECT_EQ(rig.request(Load{}).type(), MsgType::kAck);
}

TYPED_TEST(DeviceStorage, MediumFailuresAreReportedNotHidden) {
    Rig<TypeParam> rig(this->hooks());
    this->commission(rig);
    this->mem.set_fail(true);
    this->expect_error(rig.request(Save{}), ErrorCode::kStorage, "storage", "storage");
    this->expect_error(rig.request(Load{}), ErrorCode::kStorage, "storage", "storage");
    this->expect_error(rig.request(Forget{}), ErrorCode::kStorage, "storage", "storage");
    Rig<TypeParam> rebooted(this->hooks());
    EXPECT_EQ(rebooted.device->boot_from_storage(), StorageState::kReadFailed);
}

TYPED_TEST(DeviceStorage, BodyMustBeEmpty) {
    Rig<TypeParam> rig(this->hooks());
    const uint16_t seq = 77;
    std::vector<uint8_t> f(kMaxFrameSize);
    std::array<uint8_t, kMaxPayload + kCrcSize> scratch{};
    Writer w(std::span<uint8_t>(scratch.data(), kMaxPayload));
    w.u8(static_cast<uint8_t>(MsgType::kSave));
    w.u8(kProtocolVersion);
    w.u16(seq);
    w.u8(1);  // one body byte: Save has none
    const std::size_t n = seal_frame(scratch, w.size(), f);
    ASSERT_GT(n, 0u);
    const auto replies = rig.send_bytes(std::span<const uint8_t>(f.data(), n));
    ASSERT_EQ(replies.size(), 1u);
    this->expect_error(replies[0], ErrorCode::kMalformed, "", "body");
    EXPECT_EQ(this->mem.writes(), 0);
}
