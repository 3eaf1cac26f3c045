// The stored parameter record: a round trip returns the set exactly, and
// every kind of damage is told apart and named (the field of the check that
// failed), so the status can say why a board ignored its stored set.
#include <gtest/gtest.h>

#include <array>
#include <cstring>
#include <vector>

#include "piezoloop/reference_stage.hpp"
#include "piezoloop/storage/stored_params.hpp"

using namespace piezoloop;
using namespace piezoloop::storage;

namespace {

StoredParams sample_set(bool with_optional) {
    const PipelineParams p = reference::params(true, true, false);
    StoredParams s;
    link::set_text(s.firmware_version, "1.2.3");
    s.loop_rate_Hz = 100000.0f;
    StoredAxis& a = s.axes[0];
    a.limits = params::limits_of(p);
    a.feedforward = params::feedforward_of(p);
    a.feedback = params::feedback_of(p);
    a.rc = params::rc_of(p);
    s.link.client_timeout_s = 2.5f;
    if (!with_optional) return s;  // unset groups keep their defaults: they are not stored
    a.has_trajectory = true;
    a.trajectory.waveform = Waveform::kTable;
    a.trajectory.amplitude_um = 3.0f;
    a.trajectory.table_count = 3;
    a.trajectory.table[0] = 0.25f;
    a.trajectory.table[1] = -0.5f;
    a.trajectory.table[2] = 1.0f;
    s.has_recorder = true;
    s.recorder.channel_count = 4;
    s.recorder.channels = {0, 1, 2, 3};
    s.recorder.decimation = 7;
    return s;
}

// Three axes, each with its own groups, a trajectory on the second only,
// the recorder on channels of every axis, and mixing matrices.
StoredParams three_axis_set() {
    StoredParams s = sample_set(false);
    s.axis_count = 3;
    for (uint8_t i = 1; i < 3; ++i) {
        s.axes[i] = s.axes[0];
        s.axes[i].limits.limits.u_max_V = 50.0f + i;
    }
    s.axes[1].has_trajectory = true;
    s.axes[1].trajectory.amplitude_um = 7.0f;
    s.has_recorder = true;
    s.recorder.channel_count = 8;
    s.recorder.channels = {1, 3, 1, 3, 1, 3, 0, 7};
    s.recorder.axes = {0, 0, 1, 1, 2, 2, 0, 2};
    s.recorder.trigger_axis = 2;
    s.input_matrix.axis_count = 3;
    s.input_matrix.gain[1] = 0.02f;
    s.input_matrix.offset_um[2] = 1.5f;
    s.output_matrix.axis_count = 3;
    s.output_matrix.gain[3] = -0.03f;
    return s;
}

std::vector<uint8_t> encode(const StoredParams& s) {
    std::vector<uint8_t> out(kStoredParamsMaxBytes);
    const std::size_t n = encode_stored_params(s, out);
    EXPECT_GT(n, kBlobHeaderBytes);
    out.resize(n);
    return out;
}

RecordCheck decode(const std::vector<uint8_t>& bytes, StoredParams& out, const char* version = "1.2.3") {
    return decode_stored_params(bytes, version, out);
}

// Fixes the header's CRC after a deliberate change to the body, so that the
// check under test (not the CRC) is the one that fails.
void reseal(std::vector<uint8_t>& bytes) {
    const std::span<const uint8_t> body(bytes.data() + kBlobHeaderBytes, bytes.size() - kBlobHeaderBytes);
    const uint32_t crc = link::crc32(body);
    for (int i = 0; i < 4; ++i) bytes[12 + i] = static_cast<uint8_t>(crc >> (8 * i));
}

void expect_named(const RecordCheck& c, StorageState state, const char* field) {
    EXPECT_EQ(c.state, state) << link::storage_state_name(c.state);
    ASSERT_FALSE(c.why.ok());
    EXPECT_STREQ(c.why.field, field) << c.why.message;
    EXPECT_NE(c.why.message, nullptr);
}

}  // namespace

TEST(StoredParams, RoundTripIsExact) {
    for (const bool optional : {false, true}) {
        const StoredParams s = sample_set(optional);
        StoredParams back;
        const RecordCheck c = decode(encode(s), back);
        EXPECT_EQ(c.state, StorageState::kApplied);
        EXPECT_TRUE(c.why.ok());
        EXPECT_EQ(back, s);
    }
}

TEST(StoredParams, ThreeAxesRoundTripExactly) {
    const StoredParams s = three_axis_set();
    StoredParams back;
    ASSERT_EQ(decode(encode(s), back).state, StorageState::kApplied);
    EXPECT_EQ(back, s);
    EXPECT_FALSE(back.axes[0].has_trajectory);
    EXPECT_TRUE(back.axes[1].has_trajectory);
}

TEST(StoredParams, FitsTheDeclaredMaximumAndRefusesASmallBuffer) {
    StoredParams s = three_axis_set();
    for (StoredAxis& a : s.axes) {
        a.has_trajectory = true;
        a.trajectory.table_count = static_cast<uint16_t>(params::kMaxWaveTable);
        a.feedback.sos_count = kMaxControllerSections;
    }
    std::vector<uint8_t> out(kStoredParamsMaxBytes);
    const std::size_t n = encode_stored_params(s, out);
    EXPECT_GT(n, 0u);
    EXPECT_LE(n, kStoredParamsMaxBytes);
    std::vector<uint8_t> small(n - 1);
    EXPECT_EQ(encode_stored_params(s, small), 0u);
}

TEST(StoredParams, NothingStoredIsEmpty) {
    StoredParams back;
    EXPECT_EQ(decode({}, back).state, StorageState::kEmpty);
    const std::vector<uint8_t> erased(4096, 0xFF);  // an erased flash sector
    EXPECT_EQ(decode(erased, back).state, StorageState::kEmpty);
}

TEST(StoredParams, CrcDamageIsCorrupt) {
    auto bytes = encode(sample_set(true));
    bytes[bytes.size() / 2] ^= 0x01;
    StoredParams back;
    expect_named(decode(bytes, back), StorageState::kCorrupt, "crc");
}

TEST(StoredParams, BadMagicIsCorrupt) {
    auto bytes = encode(sample_set(false));
    bytes[0] ^= 0x40;
    StoredParams back;
    expect_named(decode(bytes, back), StorageState::kCorrupt, "magic");
}

TEST(StoredParams, OtherFormatVersionIsOtherFirmware) {
    // Format 1 (one axis, before axes) and any other.
    for (const uint8_t version : {uint8_t{1}, uint8_t{3}}) {
        auto bytes = encode(sample_set(false));
        bytes[4] = version;
        StoredParams back;
        expect_named(decode(bytes, back), StorageState::kOtherFirmware, "version");
    }
}

TEST(StoredParams, OtherFirmwareVersionIsOtherFirmware) {
    const auto bytes = encode(sample_set(false));
    StoredParams back;
    expect_named(decode(bytes, back, "1.2.4"), StorageState::kOtherFirmware, "firmware_version");
}

TEST(StoredParams, OtherProtocolVersionIsOtherFirmware) {
    StoredParams s = sample_set(false);
    s.protocol_version = static_cast<uint8_t>(link::kProtocolVersion - 1);
    StoredParams back;
    expect_named(decode(encode(s), back), StorageState::kOtherFirmware, "protocol_version");
}

TEST(StoredParams, ImpossibleLengthIsCorrupt) {
    auto bytes = encode(sample_set(false));
    const uint32_t too_long = static_cast<uint32_t>(kStoredParamsMaxBodyBytes + 1);
    for (int i = 0; i < 4; ++i) bytes[8 + i] = static_cast<uint8_t>(too_long >> (8 * i));
    StoredParams back;
    expect_named(decode(bytes, back), StorageState::kCorrupt, "length");
}

TEST(StoredParams, TruncatedRecordIsCorrupt) {
    const auto whole = encode(sample_set(true));
    StoredParams back;
    // Cut inside the body, and inside the header.
    for (const std::size_t n : {whole.size() - 1, whole.size() / 2, kBlobHeaderBytes + 1, std::size_t{10}}) {
        const std::vector<uint8_t> cut(whole.begin(), whole.begin() + static_cast<std::ptrdiff_t>(n));
        expect_named(decode(cut, back), StorageState::kCorrupt, "length");
    }
}

TEST(StoredParams, TrailingBytesAfterTheRecordAreIgnored) {
    auto bytes = encode(sample_set(true));
    bytes.resize(bytes.size() + 64, 0xFF);  // the rest of a flash sector
    StoredParams back;
    EXPECT_EQ(decode(bytes, back).state, StorageState::kApplied);
    EXPECT_EQ(back, sample_set(true));
}

TEST(StoredParams, MalformedGroupsAreCorruptEvenWithAGoodCrc) {
    const auto good = encode(sample_set(false));
    StoredParams back;
    const std::size_t first_group = kBlobHeaderBytes + kStoredParamsPreambleBytes;
    {
        auto bytes = good;
        bytes[first_group] = 0x7F;  // unknown group id
        reseal(bytes);
        expect_named(decode(bytes, back), StorageState::kCorrupt, "groups");
    }
    {
        auto bytes = good;
        bytes[first_group - 1] -= 1;  // count says one group less than there are
        reseal(bytes);
        expect_named(decode(bytes, back), StorageState::kCorrupt, "groups");
    }
    {
        auto bytes = good;
        bytes[first_group - 1] += 1;  // one more group than stored: the body ends early
        reseal(bytes);
        expect_named(decode(bytes, back), StorageState::kCorrupt, "groups");
    }
}

TEST(StoredParams, AxesBeyondTheCountAreCorrupt) {
    const auto good = encode(three_axis_set());
    StoredParams back;
    const std::size_t first_group = kBlobHeaderBytes + kStoredParamsPreambleBytes;
    for (const uint8_t count : {uint8_t{0}, uint8_t{4}}) {
        auto bytes = good;
        bytes[first_group - 2] = count;  // the axis count
        reseal(bytes);
        expect_named(decode(bytes, back), StorageState::kCorrupt, "axis_count");
    }
    {
        auto bytes = good;
        bytes[first_group - 2] = 2;  // groups of axis 2 are then beyond it
        reseal(bytes);
        expect_named(decode(bytes, back), StorageState::kCorrupt, "groups");
    }
    {
        auto bytes = good;
        bytes[first_group + 1] = 3;  // the first group's axis
        reseal(bytes);
        expect_named(decode(bytes, back), StorageState::kCorrupt, "groups");
    }
}

TEST(StoredParams, EveryByteFlipIsDetected) {
    const auto good = encode(sample_set(true));
    StoredParams back;
    for (std::size_t i = 0; i < good.size(); ++i) {
        auto bytes = good;
        bytes[i] ^= 0x10;
        const RecordCheck c = decode(bytes, back);
        EXPECT_NE(c.state, StorageState::kApplied) << "byte " << i;
        EXPECT_NE(c.state, StorageState::kEmpty) << "byte " << i;
    }
}
