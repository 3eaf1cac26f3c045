// The self-test's board-case blob: round trip of every field, the layout at
// the documented offsets (counted here from the field list, independently
// of the encoder), and every rejection -- each names the field and leaves
// the output untouched. Exact comparisons throughout: the blob carries bit
// patterns (floats as IEEE-754 words, doubles as 64-bit words).
#include <gtest/gtest.h>

#include <array>
#include <cstring>
#include <functional>
#include <string>
#include <vector>

#include "piezoloop/board_case.hpp"
#include "piezoloop/link/crc32.hpp"
#include "piezoloop/reference_run.hpp"
#include "piezoloop/reference_stage.hpp"

using namespace piezoloop;

namespace {

constexpr std::size_t kProfileBytes = kEmulationProfileHeaderBytes + kEmulationProfileBodyBytes;
// Body offsets from the layout comment of board_case.hpp.
constexpr std::size_t kTicksAt = kBoardCaseHeaderBytes + kBoardCaseNameBytes;
constexpr std::size_t kMetricAt = kTicksAt + 4;
constexpr std::size_t kSampleAt = kMetricAt + 4;
constexpr std::size_t kProfileAt = kSampleAt + 1;
constexpr std::size_t kLimitsAt = kProfileAt + kProfileBytes;
constexpr std::size_t kFeedforwardAt = kLimitsAt + 16;

// A case with distinct non-default values in every part: the reference
// controller with RC, a Dahl model, PID settings, a table wave.
BoardCase sample_case() {
    BoardCase c;
    const char name[] = "janaideh2016/ff_fb";
    std::memcpy(c.name.data(), name, sizeof name);
    c.ticks = 20000;
    c.metric_start_tick = 19000;
    c.sample = link::SampleFormat::kQ31;
    EmulationProfile& p = c.profile;
    p.loop_rate_Hz = 50000;
    p.position_full_scale_um = 64.0f;
    p.voltage_full_scale_V = 16.0f;
    p.stage.rate_Hz = 50000.0f;
    p.stage.plant = reference::plant();
    p.stage.sensor.gain = 0.5f;
    c.params = reference::params(true, true, true);
    c.params.dahl = kAhmad2020Dahl;
    c.params.pid = PidConfig{1.3f, 40000.0f, 1e-6f, 5000.0f, -1.0f, 10.0f};
    link::TrajectoryParams& t = c.trajectory;
    t.waveform = Waveform::kTable;
    t.amplitude_um = 5.0f;
    t.offset_um = 5.0f;
    t.frequency_Hz = 1000.0f;
    t.cycles = 7;
    t.start_phase_cycles = 0.25f;
    t.return_fraction = 0.2f;
    t.duty = 0.3f;
    t.table_count = 5;
    t.table[0] = -1.0f;
    t.table[1] = -0.5f;
    t.table[2] = 0.0f;
    t.table[3] = 0.5f;
    t.table[4] = 1.0f;
    return c;
}

std::vector<uint8_t> encode(const BoardCase& c) {
    std::vector<uint8_t> b(kBoardCaseSlotBytes, 0xA5);
    const std::size_t n = encode_board_case(c, b);
    EXPECT_GT(n, kBoardCaseHeaderBytes);
    b.resize(n);
    return b;
}

uint32_t le32(const std::vector<uint8_t>& b, std::size_t at) {
    return uint32_t{b.at(at)} | uint32_t{b.at(at + 1)} << 8 | uint32_t{b.at(at + 2)} << 16 | uint32_t{b.at(at + 3)} << 24;
}
void put32(std::vector<uint8_t>& b, std::size_t at, uint32_t v) {
    for (std::size_t i = 0; i < 4; ++i) b.at(at + i) = static_cast<uint8_t>(v >> (8 * i));
}
// Re-seals the body CRC after a test edited the body.
void reseal(std::vector<uint8_t>& b) {
    put32(b, 12, link::crc32(std::span<const uint8_t>(b).subspan(kBoardCaseHeaderBytes)));
}

// A marker case the decoder must leave as it is when it rejects.
BoardCase marker() {
    BoardCase m;
    m.ticks = 4242;
    m.name[0] = 'm';
    return m;
}

}  // namespace

TEST(BoardCase, RoundTripIsExact) {
    const BoardCase c = sample_case();
    const auto b = encode(c);
    BoardCase d;
    const Status s = decode_board_case(b, d);
    ASSERT_TRUE(s.ok()) << (s.group ? s.group : "") << "." << s.field << ": " << s.message;
    EXPECT_STREQ(d.name.data(), "janaideh2016/ff_fb");
    EXPECT_EQ(d.ticks, c.ticks);
    EXPECT_EQ(d.metric_start_tick, c.metric_start_tick);
    EXPECT_EQ(d.sample, c.sample);
    // The profile and every parameter group: re-encoded, byte for byte.
    EXPECT_EQ(encode(d), b);
    EXPECT_EQ(d.profile.loop_rate_Hz, 50000u);
    EXPECT_EQ(d.profile.stage.sensor.gain, 0.5f);
    EXPECT_EQ(d.profile.stage.plant.pi, c.profile.stage.plant.pi);
    EXPECT_EQ(d.params.feedforward, c.params.feedforward);
    EXPECT_EQ(d.params.pi, c.params.pi);
    EXPECT_EQ(d.params.dahl, c.params.dahl);
    EXPECT_EQ(d.params.feedback, c.params.feedback);
    EXPECT_EQ(d.params.sos_count, c.params.sos_count);
    EXPECT_EQ(d.params.sos, c.params.sos);
    EXPECT_EQ(d.params.pid, c.params.pid);
    EXPECT_EQ(d.params.rc_enabled, true);
    EXPECT_EQ(d.params.rc.period_samples, c.params.rc.period_samples);
    EXPECT_EQ(d.params.rc.k_rc, c.params.rc.k_rc);
    EXPECT_EQ(d.params.rc.q, c.params.rc.q);
    EXPECT_EQ(d.params.limits.u_min_V, c.params.limits.u_min_V);
    EXPECT_EQ(d.params.limits.u_max_V, c.params.limits.u_max_V);
    EXPECT_EQ(d.params.limits.slew_V_per_s, c.params.limits.slew_V_per_s);
    EXPECT_EQ(d.params.limits.saturation_trip_s, c.params.limits.saturation_trip_s);
    EXPECT_EQ(d.trajectory, c.trajectory);
}

// Fields at the documented offsets; the parameter groups are the link's
// bytes (the same write() `piezoloop set` sends).
TEST(BoardCase, LayoutAtDocumentedOffsets) {
    const BoardCase c = sample_case();
    const auto b = encode(c);
    EXPECT_EQ(le32(b, 0), 0x43425A50u);
    EXPECT_EQ(std::string(reinterpret_cast<const char*>(b.data()), 4), "PZBC");
    EXPECT_EQ(b[4] | b[5] << 8, 1);
    EXPECT_EQ(b[6] | b[7] << 8, 0);
    EXPECT_EQ(le32(b, 8), b.size() - kBoardCaseHeaderBytes);
    EXPECT_EQ(std::string(reinterpret_cast<const char*>(&b[16])), "janaideh2016/ff_fb");
    EXPECT_EQ(le32(b, kTicksAt), 20000u);
    EXPECT_EQ(le32(b, kMetricAt), 19000u);
    EXPECT_EQ(b[kSampleAt], 1);
    std::array<uint8_t, kProfileBytes> profile{};
    ASSERT_EQ(encode_profile(c.profile, profile), kProfileBytes);
    EXPECT_TRUE(std::equal(profile.begin(), profile.end(), b.begin() + kProfileAt));
    std::array<uint8_t, 2048> groups{};
    link::Writer w(groups);
    link::LimitsParams{c.params.limits}.write(w);
    link::FeedforwardParams{c.params.feedforward, c.params.pi, c.params.dahl}.write(w);
    link::FeedbackParams{c.params.feedback, c.params.sos_count, c.params.sos, c.params.pid}.write(w);
    link::RepetitiveParams{c.params.rc_enabled, c.params.rc}.write(w);
    c.trajectory.write(w);
    ASSERT_TRUE(w.ok());
    ASSERT_EQ(kLimitsAt + w.size(), b.size());
    EXPECT_TRUE(std::equal(groups.begin(), groups.begin() + static_cast<long>(w.size()), b.begin() + kLimitsAt));
    // Fits a slot with room; the slots sit below the emulation profile.
    EXPECT_LE(b.size(), kBoardCaseSlotBytes);
    EXPECT_EQ(kBoardCaseAddress + kBoardCaseSlots * kBoardCaseSlotBytes, kEmulationProfileAddress - 1024u);
}

TEST(BoardCase, WaveAtTheProfileRate) {
    const BoardCase c = sample_case();
    const TrajectoryConfig w = board_case_wave(c);
    EXPECT_EQ(w.sample_rate_Hz, 50000.0f);
    EXPECT_EQ(w.waveform, Waveform::kTable);
    EXPECT_EQ(w.frequency_Hz, 1000.0f);
    EXPECT_EQ(w.cycles, 7u);
    ASSERT_EQ(w.table.size(), 5u);
    EXPECT_EQ(w.table.data(), c.trajectory.table.data());
    TrajectoryGenerator<float, link::kMaxWaveTable> g(SignalScale{64.0f});
    EXPECT_TRUE(g.configure(w).ok());
}

TEST(BoardCase, PresenceIsTheMagic) {
    const auto b = encode(sample_case());
    EXPECT_TRUE(board_case_present(b));
    std::vector<uint8_t> erased(kBoardCaseSlotBytes, 0);
    EXPECT_FALSE(board_case_present(erased));
    EXPECT_FALSE(board_case_present(std::span<const uint8_t>(b.data(), 3)));
}

TEST(BoardCase, EncodeRefusesTooSmallOutput) {
    const BoardCase c = sample_case();
    const auto b = encode(c);
    std::vector<uint8_t> small(b.size() - 1);
    EXPECT_EQ(encode_board_case(c, small), 0u);
    std::vector<uint8_t> exact(b.size());
    EXPECT_EQ(encode_board_case(c, exact), b.size());
}

// Every rejection: (edit of a valid blob, expected group or null, field).
TEST(BoardCase, EveryRejectionNamesItsField) {
    struct Case {
        const char* what;
        std::function<void(std::vector<uint8_t>&)> edit;
        const char* group;
        const char* field;
    };
    const auto with = [](std::function<void(BoardCase&)> f) {
        return [f](std::vector<uint8_t>& b) {
            BoardCase c = sample_case();
            f(c);
            b = encode(c);
        };
    };
    const std::vector<Case> cases = {
        {"magic", [](auto& b) { b[0] ^= 1; }, nullptr, "magic"},
        {"version", [](auto& b) { b[4] = 2; }, nullptr, "version"},
        {"reserved", [](auto& b) { b[6] = 1; }, nullptr, "reserved"},
        {"short header", [](auto& b) { b.resize(15); }, nullptr, "length"},
        {"length beyond data", [](auto& b) { put32(b, 8, le32(b, 8) + 1); }, nullptr, "length"},
        {"length beyond slot", [](auto& b) { put32(b, 8, 2048); }, nullptr, "length"},
        {"body cut", [](auto& b) { b.pop_back(); }, nullptr, "length"},
        {"crc", [](auto& b) { b[kTicksAt] ^= 1; }, nullptr, "crc"},
        {"body longer than fields",
         [](auto& b) {
             b.push_back(0);
             put32(b, 8, le32(b, 8) + 1);
             reseal(b);
         },
         nullptr, "length"},
        {"body shorter than profile",
         [](auto& b) {
             b.resize(kProfileAt + 10);
             put32(b, 8, static_cast<uint32_t>(b.size() - kBoardCaseHeaderBytes));
             reseal(b);
         },
         nullptr, "length"},
        {"body ends inside a group",
         [](auto& b) {
             b.resize(kFeedforwardAt + 3);
             put32(b, 8, static_cast<uint32_t>(b.size() - kBoardCaseHeaderBytes));
             reseal(b);
         },
         nullptr, "length"},
        {"name empty", with([](BoardCase& c) { c.name.fill('\0'); }), nullptr, "name"},
        {"name quote", with([](BoardCase& c) { c.name[3] = '"'; }), nullptr, "name"},
        {"name control", with([](BoardCase& c) { c.name[0] = '\n'; }), nullptr, "name"},
        {"name after padding",
         [](auto& b) {
             b[16 + 40] = 'x';
             reseal(b);
         },
         nullptr, "name"},
        {"name unterminated",
         [](auto& b) {
             for (std::size_t i = 0; i < kBoardCaseNameBytes; ++i) b[16 + i] = 'a';
             reseal(b);
         },
         nullptr, "name"},
        {"ticks 0", with([](BoardCase& c) { c.ticks = 0; c.metric_start_tick = 0; }), nullptr, "ticks"},
        {"metric start", with([](BoardCase& c) { c.metric_start_tick = c.ticks; }), nullptr, "metric_start_tick"},
        {"sample", with([](BoardCase& c) { c.sample = static_cast<link::SampleFormat>(2); }), nullptr, "sample"},
        {"profile magic",
         [](auto& b) {
             b[kProfileAt] ^= 1;
             reseal(b);
         },
         "profile", "magic"},
        {"profile crc",
         [](auto& b) {
             b[kProfileAt + 20] ^= 1;
             reseal(b);
         },
         "profile", "crc"},
        {"profile rate", with([](BoardCase& c) { c.profile.loop_rate_Hz = 300000; c.profile.stage.rate_Hz = 3e5f; }),
         "profile", "loop_rate_Hz"},
        {"profile stage", with([](BoardCase& c) { c.profile.stage.plant.sections = 7; }), "plant", "sections"},
        {"limits... feedforward count",
         [](auto& b) {
             b[kFeedforwardAt + 13] = 17;  // kind u8, 3 x f32, then the operator count
             reseal(b);
         },
         "feedforward", "encoding"},
        {"rc boolean",
         [](auto& b) {
             BoardCase c = sample_case();
             std::array<uint8_t, 2048> g{};
             link::Writer w(g);
             link::FeedforwardParams{c.params.feedforward, c.params.pi, c.params.dahl}.write(w);
             link::FeedbackParams{c.params.feedback, c.params.sos_count, c.params.sos, c.params.pid}.write(w);
             b[kFeedforwardAt + w.size()] = 2;  // RepetitiveParams::enabled
             reseal(b);
         },
         "rc", "encoding"},
        {"trajectory table count",
         [](auto& b) {
             // TrajectoryParams: u8 waveform, 4 x f32, u32, 3 x f32, then the u16 count.
             const std::size_t at = b.size() - 5 * 4 - 2;
             b[at] = 97;
             reseal(b);
         },
         "trajectory", "encoding"},
    };
    for (const Case& k : cases) {
        std::vector<uint8_t> b = encode(sample_case());
        k.edit(b);
        BoardCase out = marker();
        const Status s = decode_board_case(b, out);
        ASSERT_FALSE(s.ok()) << k.what;
        EXPECT_STREQ(s.field, k.field) << k.what << ": " << (s.message ? s.message : "");
        if (k.group == nullptr) EXPECT_EQ(s.group, nullptr) << k.what << ": group " << s.group;
        else EXPECT_STREQ(s.group, k.group) << k.what;
        EXPECT_NE(s.message, nullptr) << k.what;
        EXPECT_EQ(out.ticks, 4242u) << k.what << ": output written on rejection";
        EXPECT_EQ(out.name[0], 'm') << k.what;
    }
}
