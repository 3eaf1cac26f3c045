// Round trips of every message layout through encode -> frame -> decode, with
// seeded random contents (bit patterns, so NaN payloads and negative zeros
// travel too), and the layout checks: short, long and ill-formed bodies.
#include <gtest/gtest.h>

#include <bit>
#include <cstring>
#include <random>
#include <vector>

#include "piezoloop/link/messages.hpp"

using namespace piezoloop;
using namespace piezoloop::link;

namespace {

std::mt19937 gen(42);
uint32_t r32() { return static_cast<uint32_t>(gen()); }
float rf() { return std::bit_cast<float>(static_cast<uint32_t>(r32())); }
double rd() { return std::bit_cast<double>((uint64_t{r32()} << 32) | r32()); }
uint8_t r8() { return static_cast<uint8_t>(r32()); }

// Bitwise equality: random floats include NaNs, which == would reject.
template <class M>
bool same_bits(const M& a, const M& b) {
    std::vector<uint8_t> fa(kMaxFrameSize), fb(kMaxFrameSize);
    const std::size_t na = encode_message(a, 0, fa), nb = encode_message(b, 0, fb);
    return na == nb && na > 0 && std::memcmp(fa.data(), fb.data(), na) == 0;
}

template <class M>
M round_trip(const M& m, uint16_t seq) {
    std::vector<uint8_t> f(kMaxFrameSize);
    const std::size_t n = encode_message(m, seq, f);
    EXPECT_GT(n, 0u);
    EXPECT_LE(n, kMaxFrameSize);
    for (std::size_t i = 0; i + 1 < n; ++i) EXPECT_NE(f[i], 0) << "COBS output contains a zero";
    EXPECT_EQ(f[n - 1], 0);
    FrameDecoder dec;
    M out{};
    int got = 0;
    dec.feed(std::span<const uint8_t>(f.data(), n), [&](std::span<const uint8_t> p) {
        ++got;
        const FrameHeader h = parse_header(p);
        EXPECT_EQ(h.type, static_cast<uint8_t>(M::kType));
        EXPECT_EQ(h.version, kProtocolVersion);
        EXPECT_EQ(h.seq, seq);
        EXPECT_EQ(decode_body(p.subspan(kHeaderSize), out), DecodeResult::kOk);
        // Every strict prefix is short; one byte more is too long.
        std::vector<uint8_t> body(p.begin() + kHeaderSize, p.end());
        if (!body.empty()) {
            M tmp{};
            EXPECT_EQ(decode_body(std::span<const uint8_t>(body).first(body.size() - 1), tmp), DecodeResult::kTruncated);
        }
        body.push_back(0);
        M tmp{};
        EXPECT_EQ(decode_body(std::span<const uint8_t>(body), tmp), DecodeResult::kTooLong);
    });
    EXPECT_EQ(got, 1);
    return out;
}

template <class M>
void check(const M& m) {
    const uint16_t seq = static_cast<uint16_t>(r32());
    const M out = round_trip(m, seq);
    EXPECT_TRUE(same_bits(m, out)) << "type " << int(M::kType);
}

template <std::size_t N>
void rtext(std::array<char, N>& a) {
    const std::size_t n = r32() % N;  // leaves room for the terminator
    a = {};
    for (std::size_t i = 0; i < n; ++i) a[i] = static_cast<char>(1 + r32() % 126);
}

FeedforwardParams random_ff() {
    FeedforwardParams v;
    v.kind = static_cast<FeedforwardKind>(r8() % 5);  // none .. pi_series
    v.pi.input_gain = rf(); v.pi.input_offset = rf(); v.pi.p0 = rf();
    v.pi.count = static_cast<int>(r32() % (kMaxPlayOperators + 1));
    for (int j = 0; j < v.pi.count; ++j) { v.pi.thresholds[j] = rf(); v.pi.weights[j] = rf(); }
    v.dahl = DahlParams{rf(), rf(), rf(), rf(), rf(), rf()};
    return v;
}
FeedbackParams random_fb() {
    FeedbackParams v;
    v.kind = static_cast<FeedbackKind>(r8() % 3);
    v.sos_count = static_cast<int>(r32() % 5);
    for (auto& s : v.sos) s = SosSection{rd(), rd(), rd(), rd(), rd()};
    v.pid = PidConfig{rf(), rf(), rf(), rf(), rf(), rf()};
    return v;
}
RepetitiveParams random_rc() {
    RepetitiveParams v;
    v.enabled = r32() % 2;
    v.rc.period_samples = static_cast<int>(r32()); v.rc.m1 = static_cast<int>(r32()); v.rc.m2 = static_cast<int>(r32());
    v.rc.k_rc = rf();
    v.rc.q = SosSection{rd(), rd(), rd(), rd(), rd()};
    return v;
}
TrajectoryParams random_traj() {
    TrajectoryParams v;
    v.waveform = static_cast<Waveform>(r8() % 6);
    v.amplitude_um = rf(); v.offset_um = rf(); v.frequency_Hz = rf(); v.cycles = r32();
    v.start_phase_cycles = rf(); v.return_fraction = rf(); v.duty = rf();
    v.table_count = static_cast<uint16_t>(r32() % (kMaxWaveTable + 1));
    for (std::size_t i = 0; i < v.table_count; ++i) v.table[i] = rf();
    return v;
}
RecorderParams random_rec() {
    RecorderParams v;
    v.channel_count = static_cast<uint8_t>(r32() % (kMaxLogChannels + 1));
    for (auto& c : v.channels) c = r8();
    v.decimation = r32(); v.mode = static_cast<RecordMode>(r8() % 2); v.trigger = static_cast<TriggerMode>(r8() % 3);
    v.trigger_signal = r8(); v.trigger_level = rf(); v.pre_trigger = r32(); v.length = r32();
    return v;
}

}  // namespace

TEST(LinkMessages, RoundTripEveryMessage) {
    for (int t = 0; t < 300; ++t) {
        check(Hello{}); check(GetStatus{}); check(Arm{}); check(Disarm{}); check(ClearTrip{});
        check(StartWave{}); check(StopWave{}); check(RecorderArm{}); check(RecorderStop{});
        check(StopExcitation{});
        StartExcitation x;
        x.flags = r8(); x.config.signal = static_cast<ExcitationSignal>(r8());
        x.config.point = static_cast<ExcitationPoint>(r8() % 2);
        x.config.amplitude = rf(); x.config.offset = rf();
        x.config.period_samples = r32(); x.config.first_bin = r32(); x.config.last_bin = r32();
        x.config.f1_Hz = rf(); x.config.f2_Hz = rf();
        x.config.prbs_order = r8(); x.config.prbs_hold = r32(); x.config.periods = r32();
        check(x);
        check(GetParams{static_cast<ParamGroup>(1 + r8() % 6)});
        check(SetParams<FeedforwardParams>{random_ff()});
        check(ParamsReply<FeedforwardParams>{random_ff()});
        check(SetParams<FeedbackParams>{random_fb()});
        check(ParamsReply<FeedbackParams>{random_fb()});
        check(SetParams<RepetitiveParams>{random_rc()});
        check(ParamsReply<RepetitiveParams>{random_rc()});
        check(SetParams<LimitsParams>{LimitsParams{LimitsConfig{rf(), rf(), rf(), rf()}}});
        check(ParamsReply<LimitsParams>{LimitsParams{LimitsConfig{rf(), rf(), rf(), rf()}}});
        check(SetParams<TrajectoryParams>{random_traj()});
        check(ParamsReply<TrajectoryParams>{random_traj()});
        check(SetParams<RecorderParams>{random_rec()});
        check(ParamsReply<RecorderParams>{random_rec()});
        check(StreamStart{static_cast<uint16_t>(r32())});
        check(StreamStop{r32() % 2 == 0});
        SetpointBlock sb;
        sb.block_seq = r32();
        sb.count = static_cast<uint8_t>(r32() % (kMaxSetpointsPerBlock + 1));
        for (std::size_t i = 0; i < sb.count; ++i) sb.setpoint_um[i] = rf();
        check(sb);
        check(SetpointAck{r32(), static_cast<uint16_t>(r32()), static_cast<uint16_t>(r32()), r32(), r32()});
        check(Ack{r8()});
        ErrorReply e;
        e.request_type = r8(); e.code = static_cast<ErrorCode>(r8() % 14); e.index = static_cast<int16_t>(r32());
        rtext(e.group); rtext(e.field); rtext(e.message);
        check(e);
        HelloReply h;
        rtext(h.board); rtext(h.firmware_version); rtext(h.serial);
        h.loop_rate_Hz = rf(); h.capabilities = r32(); h.sample_format = static_cast<SampleFormat>(r8() % 2);
        h.hard_u_min_V = rf(); h.hard_u_max_V = rf(); h.hard_slew_max_V_per_s = rf();
        h.position_full_scale_um = rf(); h.voltage_full_scale_V = rf();
        h.setpoint_capacity = static_cast<uint16_t>(r32()); h.recorder_channels = r8(); h.recorder_capacity = r32();
        h.rc_capacity = r32(); h.excitation_capacity = r32();
        check(h);
        StatusReply s;
        s.armed = r32() % 2; s.tripped = r32() % 2; s.trip_reason = static_cast<TripReason>(r8() % 6);
        s.wave_running = r32() % 2; s.streaming = r32() % 2; s.swap_pending = r32() % 2;
        s.recorder_state = static_cast<RecorderState>(r8() % 4);
        s.faults = r32(); s.tick_count = r32(); s.swaps = r32();
        s.tick = TickStats{r32(), r32(), r32(), rf(), rf(), r32()};
        s.setpoint_underruns = r32(); s.setpoint_free = static_cast<uint16_t>(r32()); s.setpoint_next_seq = r32();
        s.recorder_overruns = r32(); s.log_blocks = r32();
        s.link = LinkCounters{r32(), r32(), r32(), r32(), r32(), r32(), r32(), r32(), r32(), r32()};
        s.r_um = rf(); s.y_um = rf(); s.u_V = rf();
        s.excitation_running = r32() % 2; s.excitation_ticks = r32(); s.excitation_clipped = r32();
        s.storage = static_cast<StorageState>(r8() % kStorageStateCount);
        rtext(s.storage_group); rtext(s.storage_field); rtext(s.storage_message);
        s.storage_index = static_cast<int16_t>(r32());
        check(s);
        LogBlock b;
        b.block_seq = r32(); b.first_tick = r32(); b.tick_stride = r32(); b.recorder_overruns = r32();
        b.channel_count = static_cast<uint8_t>(1 + r32() % kMaxLogChannels);
        b.format = static_cast<SampleFormat>(r8() % 2);
        b.frame_count = static_cast<uint8_t>(r32() % (log_frames_per_block(b.channel_count) + 1));
        b.flags = r8() & 1;
        for (auto& c : b.channels) c = r8();
        for (std::size_t i = 0; i < std::size_t{b.channel_count} * b.frame_count; ++i) b.samples[i] = r32();
        check(b);
    }
}

TEST(LinkMessages, StatusReplyLayoutHasTheStorageThenTheAxesBlock) {
    // docs/protocol.md: the excitation at 113, the storage block from
    // offset 122, the axes block from 269: 42 bytes for one axis.
    StatusReply s;
    s.excitation_running = true;
    s.storage = StorageState::kRejected;
    link::set_text(s.storage_group, "feedforward");
    std::array<uint8_t, kMaxBody> body{};
    Writer w(body);
    s.write(w);
    ASSERT_TRUE(w.ok());
    EXPECT_EQ(w.size(), 269u + 42u + 13u);  // ..., one axis, the scan block
    EXPECT_EQ(body[113], 1);
    EXPECT_EQ(body[122], static_cast<uint8_t>(StorageState::kRejected));
    EXPECT_EQ(body[123], 'f');
    EXPECT_EQ(body[269], 1);  // axis_count
    // Each further axis adds its 41 bytes.
    s.axis_count = 3;
    Writer w3(body);
    s.write(w3);
    EXPECT_EQ(w3.size(), 269u + 1u + 3u * 41u + 13u);
}

TEST(LinkMessages, StorageRequestsAreRequests) {
    for (const MsgType t : {MsgType::kSave, MsgType::kLoad, MsgType::kForget})
        EXPECT_TRUE(is_request(static_cast<uint8_t>(t)));
    EXPECT_EQ(static_cast<uint8_t>(MsgType::kSave), 0x11);
    EXPECT_EQ(static_cast<uint8_t>(MsgType::kLoad), 0x12);
    EXPECT_EQ(static_cast<uint8_t>(MsgType::kForget), 0x13);
}

TEST(LinkMessages, LargestMessagesFitTheFrame) {
    // Full-size variants of every variable-length message fit kMaxPayload.
    SetpointBlock sb;
    sb.count = kMaxSetpointsPerBlock;
    TrajectoryParams tp;
    tp.table_count = kMaxWaveTable;
    FeedforwardParams ff;
    ff.pi.count = kMaxPlayOperators;
    std::vector<uint8_t> f(kMaxFrameSize);
    EXPECT_GT(encode_message(sb, 1, f), 0u);
    EXPECT_GT(encode_message(SetParams<TrajectoryParams>{tp}, 1, f), 0u);
    EXPECT_GT(encode_message(SetParams<FeedforwardParams>{ff}, 1, f), 0u);
    EXPECT_GT(encode_message(SetParams<FeedbackParams>{}, 1, f), 0u);
    EXPECT_GT(encode_message(StatusReply{}, 1, f), 0u);
    EXPECT_GT(encode_message(HelloReply{}, 1, f), 0u);
    EXPECT_GT(encode_message(ErrorReply{}, 1, f), 0u);
    EXPECT_GT(encode_message(StartExcitation{}, 1, f), 0u);
    for (std::size_t ch = 1; ch <= kMaxLogChannels; ++ch) {
        LogBlock b;
        b.channel_count = static_cast<uint8_t>(ch);
        b.frame_count = static_cast<uint8_t>(log_frames_per_block(ch));
        // 480 bytes of samples whatever the channel count (1..8 divide 120 or leave < 1 frame)
        EXPECT_LE(ch * b.frame_count * 4, kMaxBody - kLogBlockHeader);
        EXPECT_GT(encode_message(b, 0, f), 0u) << ch;
    }
}

TEST(LinkMessages, HelloReplyCarriesTheStm32UniqueIdWhole) {
    // The STM32's serial is its 96-bit unique ID as 24 hex digits
    // (common/piezoloop/usb/serial_number.hpp); all 24 must arrive (version 1 cut
    // the last one), and a text longer than the field keeps its zero.
    HelloReply h;
    const char* uid = "0123456789ABCDEF01234567";
    set_text(h.serial, uid);
    EXPECT_STREQ(round_trip(h, 3).serial.data(), uid);
    set_text(h.serial, "0123456789ABCDEF0123456789ABCDEF-too-long");
    EXPECT_STREQ(round_trip(h, 4).serial.data(), "0123456789ABCDEF0123456789ABCDE");
}

TEST(LinkMessages, IllFormedBodiesAreRejected) {
    // A boolean that is neither 0 nor 1.
    StreamStop ss;
    const std::vector<uint8_t> two{2};
    EXPECT_EQ(decode_body(std::span<const uint8_t>(two), ss), DecodeResult::kBadValue);
    // A count beyond its array.
    std::vector<uint8_t> body(5 + kMaxSetpointsPerBlock * 4 + 4, 0);
    body[4] = static_cast<uint8_t>(kMaxSetpointsPerBlock + 1);
    SetpointBlock sb;
    EXPECT_EQ(decode_body(std::span<const uint8_t>(body), sb), DecodeResult::kBadValue);
    // A parameter body whose group id does not match its layout.
    std::vector<uint8_t> f(kMaxFrameSize);
    SetParams<LimitsParams> lp;
    std::array<uint8_t, 64> buf{};
    Writer w(buf);
    lp.write(w);
    buf[0] = static_cast<uint8_t>(ParamGroup::kFeedback);
    EXPECT_EQ(decode_body(std::span<const uint8_t>(buf.data(), w.size()), lp), DecodeResult::kBadValue);
}

TEST(LinkMessages, UsbFullSpeedLogBudget) {
    // docs/protocol.md section 8, computed from the real encoder: a full log
    // block whose fields contain no zero byte (the largest COBS overhead),
    // 100 kHz, against the USB full-speed bulk ceiling of 19 packets of 64
    // bytes per 1 ms frame.
    constexpr double kUsbBytesPerSecond = 19.0 * 64.0 * 1000.0;
    constexpr double kRate_Hz = 100000.0;
    std::size_t fit = 0;
    for (std::size_t ch = 1; ch <= kMaxLogChannels; ++ch) {
        LogBlock b;
        b.block_seq = b.first_tick = b.tick_stride = b.recorder_overruns = 0x01010101u;
        b.channel_count = static_cast<uint8_t>(ch);
        b.format = SampleFormat::kQ31;
        b.frame_count = static_cast<uint8_t>(log_frames_per_block(ch));
        b.flags = LogBlock::kFlagLast;
        b.channels = {1, 2, 3, 4, 5, 6, 7, 8};
        for (auto& s : b.samples) s = 0x3F8CCCCDu;  // 1.1f: no zero bytes
        std::vector<uint8_t> f(kMaxFrameSize);
        std::size_t wire = encode_message(b, 0x0101, f);
        // 520 unless the CRC itself holds a zero byte (which saves one).
        if (std::size_t{b.frame_count} * ch * 4 == 480) {  // not 7 channels: 17 frames, 476 bytes
            EXPECT_GE(wire, 519u) << ch;
        }
        EXPECT_LE(wire, kMaxFrameSize);
        if (ch <= 4) {
            EXPECT_EQ(std::size_t{b.frame_count} * ch * 4, 480u);
        }
        wire = kMaxFrameSize;  // budget on the worst case
        const double bytes_per_s = kRate_Hz / static_cast<double>(b.frame_count) * static_cast<double>(wire);
        if (bytes_per_s <= kUsbBytesPerSecond) fit = ch;
    }
    EXPECT_EQ(fit, 2u);
}
