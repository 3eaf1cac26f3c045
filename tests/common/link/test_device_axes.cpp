// The link device over 1, 2 and 3 axes (a MultiAxisPipeline): the hello and
// the status report every axis; every axis has its own groups; an axis index
// at or beyond the count is refused naming `axis` and changes nothing; the
// matrices are validated and refused while armed, changing nothing; the
// recorder takes (axis, signal) channels of different axes; a stored set
// holds every axis; and one axis over a MultiAxisPipeline logs exactly what
// a device over a Pipeline logs.
#include <gtest/gtest.h>

#include <array>
#include <bit>
#include <cstring>
#include <memory>
#include <type_traits>
#include <vector>

#include "piezoloop/link/device.hpp"
#include "piezoloop/reference_stage.hpp"
#include "piezoloop/scan/scan_feed.hpp"
#include "piezoloop/storage/memory_storage.hpp"
#include "test_link_client.hpp"

using namespace piezoloop;
using namespace piezoloop::link;
using link_test::Reply;

namespace {

// A device over N axes, each the reference stage's setup, 8 recorder channels.
template <class T, int N>
struct AxesRig {
    using DeviceT = Device<T, 1024, 8, 1024, 1024, 1024, N, true>;
    using MultiT = typename DeviceT::MultiType;
    std::unique_ptr<MultiT> multi;
    std::unique_ptr<DeviceT> device;
    FrameDecoder host_rx;
    std::vector<Reply> replies;
    uint16_t seq = 0;

    static MultiAxisSetup<N> setup() {
        MultiAxisSetup<N> s{};
        for (int i = 0; i < N; ++i) {
            s.axes[i] = reference::setup();
            s.channels[i] = reference::setup().hard;
        }
        return s;
    }

    explicit AxesRig(const DeviceHooks& hooks = {})
        : multi(std::make_unique<MultiT>(setup())),
          device(std::make_unique<DeviceT>(*multi, DeviceInfo{"test-xyz", "1.2.3", "SN0003"}, hooks)) {}

    auto sink() {
        return [this](std::span<const uint8_t> frame) {
            host_rx.feed(frame, [this](std::span<const uint8_t> payload) {
                Reply r;
                r.header = parse_header(payload);
                r.body.assign(payload.begin() + kHeaderSize, payload.end());
                replies.push_back(std::move(r));
            });
        };
    }
    template <class M>
    Reply request(const M& m) {
        const uint16_t s = ++seq;
        std::vector<uint8_t> f(kMaxFrameSize);
        f.resize(encode_message(m, s, f));
        replies.clear();
        device->receive(f, sink());
        EXPECT_EQ(replies.size(), 1u);
        if (replies.empty()) return Reply{};
        EXPECT_EQ(replies[0].header.seq, s);
        return replies[0];
    }
    template <class G>
    G get(uint8_t axis = 0) {
        return request(GetParams{G::kGroup, axis}).template as<ParamsReply<G>>().value;
    }
    template <class G>
    Reply set(const G& v, uint8_t axis = 0) {
        SetParams<G> m{v};
        m.axis = axis;
        return request(m);
    }
    // Every axis reads y = 0 (a stage at rest).
    void tick(int n = 1) {
        for (int i = 0; i < n; ++i) {
            device->on_tick();
            multi->tick(typename MultiT::Samples{});
        }
    }
    std::vector<LogBlock> drain_log() {
        std::vector<LogBlock> blocks;
        for (;;) {
            replies.clear();
            if (!device->poll_log(sink())) break;
            for (const Reply& r : replies) blocks.push_back(r.template as<LogBlock>());
        }
        return blocks;
    }

    // The reference controller on every axis, each with its own limits.
    void configure_reference() {
        const PipelineParams p = reference::params(true, true, false);
        for (uint8_t a = 0; a < N; ++a) {
            LimitsParams lim{p.limits};
            lim.limits.u_max_V = p.limits.u_max_V - static_cast<float>(a);
            ASSERT_EQ(set(lim, a).type(), MsgType::kAck);
            tick();
            ASSERT_EQ(set(FeedforwardParams{p.feedforward, p.pi, p.dahl}, a).type(), MsgType::kAck);
            tick();
            ASSERT_EQ(set(FeedbackParams{p.feedback, p.sos_count, p.sos, p.pid}, a).type(), MsgType::kAck);
            tick();
        }
    }
};

void expect_error(const Reply& r, ErrorCode code, const char* group, const char* field) {
    ASSERT_EQ(r.type(), MsgType::kError);
    const ErrorReply e = r.as<ErrorReply>();
    EXPECT_EQ(e.code, code) << error_code_name(e.code) << ": " << e.message.data();
    if (group != nullptr) {
        EXPECT_STREQ(e.group.data(), group);
    }
    if (field != nullptr) {
        EXPECT_STREQ(e.field.data(), field);
    }
    EXPECT_GT(std::strlen(e.message.data()), 0u);
}

template <class T>
uint32_t bits(T v) {
    if constexpr (std::is_same_v<T, float>) return std::bit_cast<uint32_t>(v); else return static_cast<uint32_t>(v.raw());
}

template <class T>
T signal_of(const TickSignals<T>& s, uint8_t signal) {
    T v;
    std::memcpy(&v, reinterpret_cast<const unsigned char*>(&s) + signal * sizeof(T), sizeof(T));
    return v;
}

template <class P>
class DeviceAxes : public ::testing::Test {};
template <class T, int N>
struct Case {
    using Sample = T;
    static constexpr int kAxes = N;
};
using Cases = ::testing::Types<Case<float, 1>, Case<float, 2>, Case<float, 3>, Case<Q31, 2>, Case<Q31, 3>>;
TYPED_TEST_SUITE(DeviceAxes, Cases);

}  // namespace

TYPED_TEST(DeviceAxes, HelloAndStatusReportEveryAxis) {
    constexpr int N = TypeParam::kAxes;
    AxesRig<typename TypeParam::Sample, N> rig;
    rig.configure_reference();
    const HelloReply h = rig.request(Hello{}).template as<HelloReply>();
    EXPECT_EQ(h.protocol_version, kProtocolVersion);
    EXPECT_EQ(h.axis_count, N);
    EXPECT_NE(h.capabilities & cap::kAxisMatrices, 0u);
    EXPECT_EQ(h.recorder_channels, 8);
    for (int a = 0; a < N; ++a) {
        EXPECT_EQ(h.axis_hard_u_max_V[a], reference::setup().hard.u_max_V);
        EXPECT_EQ(h.axis_position_full_scale_um[a], reference::setup().position.full_scale);
    }
    // Arm acts on every axis.
    ASSERT_EQ(rig.request(Arm{}).type(), MsgType::kAck);
    rig.tick(3);
    StatusReply st = rig.request(GetStatus{}).template as<StatusReply>();
    EXPECT_EQ(st.axis_count, N);
    for (int a = 0; a < N; ++a) {
        EXPECT_TRUE(st.axis_armed[a]) << a;
        EXPECT_TRUE(rig.multi->axis(a).armed()) << a;
        EXPECT_EQ(st.axis_swaps[a], rig.multi->axis(a).swaps());
    }
    EXPECT_TRUE(st.armed);
    ASSERT_EQ(rig.request(Disarm{}).type(), MsgType::kAck);
    rig.tick();
    st = rig.request(GetStatus{}).template as<StatusReply>();
    for (int a = 0; a < N; ++a) EXPECT_FALSE(st.axis_armed[a]) << a;
}

TYPED_TEST(DeviceAxes, EveryAxisHasItsOwnGroups) {
    constexpr int N = TypeParam::kAxes;
    AxesRig<typename TypeParam::Sample, N> rig;
    rig.configure_reference();
    const PipelineParams p = reference::params(true, true, false);
    for (uint8_t a = 0; a < N; ++a) {
        const LimitsParams lim = rig.template get<LimitsParams>(a);
        EXPECT_EQ(lim.limits.u_max_V, p.limits.u_max_V - static_cast<float>(a));
        EXPECT_EQ(rig.multi->axis(a).params().limits.u_max_V, lim.limits.u_max_V);
    }
    TrajectoryParams t;
    t.waveform = Waveform::kTriangle;
    t.amplitude_um = 2.0f;
    t.frequency_Hz = 100.0f;
    ASSERT_EQ(rig.set(t, static_cast<uint8_t>(N - 1)).type(), MsgType::kAck);
    EXPECT_EQ(rig.template get<TrajectoryParams>(static_cast<uint8_t>(N - 1)), t);
    if (N > 1) {
        // The other axes have no wave.
        StartWave w;
        w.axis = 0;
        expect_error(rig.request(w), ErrorCode::kNotConfigured, "trajectory", "waveform");
    }
}

// StartWave with axis 255 starts every axis's wave at the same tick
// boundary, or, if one axis cannot start, none (the error names it by index).
TYPED_TEST(DeviceAxes, EveryAxisWaveStartsTogetherOrNotAtAll) {
    constexpr int N = TypeParam::kAxes;
    AxesRig<typename TypeParam::Sample, N> rig;
    rig.configure_reference();
    StartWave every{StartWave::kArmLoop};
    every.axis = StartWave::kEveryAxis;
    TrajectoryParams t;
    t.waveform = Waveform::kTriangle;
    t.amplitude_um = 2.0f;
    t.frequency_Hz = 100.0f;
    if (N == 1) {
        ASSERT_EQ(rig.set(t, 0).type(), MsgType::kAck);
        expect_error(rig.request(every), ErrorCode::kInvalidParam, nullptr, "axis");
        return;
    }
    for (uint8_t a = 0; a + 1 < N; ++a) ASSERT_EQ(rig.set(t, a).type(), MsgType::kAck);
    const Reply refused = rig.request(every);
    expect_error(refused, ErrorCode::kNotConfigured, "trajectory", "waveform");
    EXPECT_EQ(refused.as<ErrorReply>().index, N - 1);
    rig.tick();
    for (int a = 0; a < N; ++a) {
        EXPECT_FALSE(rig.multi->axis(a).armed()) << a;
        EXPECT_FALSE(rig.multi->axis(a).wave_running()) << a;
    }
    ASSERT_EQ(rig.set(t, static_cast<uint8_t>(N - 1)).type(), MsgType::kAck);
    ASSERT_EQ(rig.request(every).type(), MsgType::kAck);
    rig.tick(3);
    for (int a = 0; a < N; ++a) {
        EXPECT_TRUE(rig.multi->axis(a).armed()) << a;
        EXPECT_TRUE(rig.multi->axis(a).wave_running()) << a;
        // Same configuration, same start: the same reference on every axis.
        EXPECT_EQ(bits(rig.multi->axis(a).last().r), bits(rig.multi->axis(0).last().r)) << a;
    }
    // A running wave refuses the next every-axis start, naming its axis.
    StartWave again;
    again.axis = StartWave::kEveryAxis;
    const Reply busy = rig.request(again);
    expect_error(busy, ErrorCode::kBusy, "trajectory", "waveform");
    EXPECT_EQ(busy.as<ErrorReply>().index, 0);
}

TYPED_TEST(DeviceAxes, AnAxisBeyondTheCountIsRefusedAndChangesNothing) {
    constexpr int N = TypeParam::kAxes;
    AxesRig<typename TypeParam::Sample, N> rig;
    rig.configure_reference();
    const uint8_t bad = static_cast<uint8_t>(N);
    const PipelineParams before = rig.multi->axis(0).params();

    expect_error(rig.request(GetParams{ParamGroup::kLimits, bad}), ErrorCode::kInvalidParam, nullptr, "axis");
    LimitsParams lim{before.limits};
    lim.limits.u_max_V -= 10.0f;
    expect_error(rig.set(lim, bad), ErrorCode::kInvalidParam, nullptr, "axis");
    TrajectoryParams t;
    t.amplitude_um = 1.0f;
    t.frequency_Hz = 10.0f;
    ASSERT_EQ(rig.set(t, 0).type(), MsgType::kAck);
    StartWave w{StartWave::kArmLoop};
    w.axis = bad;
    expect_error(rig.request(w), ErrorCode::kInvalidParam, nullptr, "axis");
    StopWave sw;
    sw.axis = 255;
    expect_error(rig.request(sw), ErrorCode::kInvalidParam, nullptr, "axis");
    StartExcitation ex;
    ex.axis = bad;
    ex.flags = StartExcitation::kArmLoop;
    expect_error(rig.request(ex), ErrorCode::kInvalidParam, nullptr, "axis");
    StopExcitation se;
    se.axis = bad;
    expect_error(rig.request(se), ErrorCode::kInvalidParam, nullptr, "axis");
    StreamStart ss;
    ss.axis = bad;
    expect_error(rig.request(ss), ErrorCode::kInvalidParam, nullptr, "axis");
    // The message names the allowed range.
    const ErrorReply e = rig.request(GetParams{ParamGroup::kLimits, bad}).template as<ErrorReply>();
    EXPECT_NE(std::strstr(e.message.data(), N == 1 ? "must be 0" : (N == 2 ? "0..1" : "0..2")), nullptr);
    // A board group names axis 0 only.
    expect_error(rig.request(GetParams{ParamGroup::kRecorder, 1}), ErrorCode::kInvalidParam, "recorder", "axis");

    rig.tick();
    for (int a = 0; a < N; ++a) {
        EXPECT_FALSE(rig.multi->axis(a).armed());
        EXPECT_FALSE(rig.multi->axis(a).wave_running());
    }
    EXPECT_EQ(rig.multi->axis(0).params().limits.u_max_V, before.limits.u_max_V);
    EXPECT_FALSE(rig.device->streaming());
}

TYPED_TEST(DeviceAxes, MatricesAreValidatedAndRefusedWhileArmedChangingNothing) {
    constexpr int N = TypeParam::kAxes;
    constexpr std::size_t L = params::kMaxGroupAxes;
    AxesRig<typename TypeParam::Sample, N> rig;
    rig.configure_reference();
    const OutputMatrixParams identity = rig.template get<OutputMatrixParams>();
    EXPECT_EQ(identity.axis_count, N);
    EXPECT_EQ(identity, OutputMatrixParams{static_cast<uint8_t>(N)});

    // A mixing matrix (within the board's block) is accepted and taken over.
    OutputMatrixParams mix = identity;
    if (N > 1) mix.gain[0 * L + 1] = -0.05f;
    mix.gain[0] = 0.98f;
    ASSERT_EQ(rig.set(mix).type(), MsgType::kAck);
    rig.tick();
    EXPECT_EQ(rig.template get<OutputMatrixParams>(), mix);
    EXPECT_EQ(rig.multi->output_matrix().m[0][0], 0.98f);

    InputMatrixParams in = rig.template get<InputMatrixParams>();
    in.offset_um[N - 1] = 2.5f;
    ASSERT_EQ(rig.set(in).type(), MsgType::kAck);
    rig.tick();
    EXPECT_EQ(rig.multi->input_matrix().offset_um[N - 1], 2.5f);

    // Singular: refused naming the matrix, nothing changes.
    OutputMatrixParams singular = identity;
    singular.gain[0] = 0.0f;
    if (N > 1) singular.gain[1 * L + 1] = 0.0f;
    expect_error(rig.set(singular), ErrorCode::kInvalidParam, "axes", nullptr);
    // Beyond the board's block: must be the identity's.
    if (N < 3) {
        OutputMatrixParams outside = mix;
        outside.gain[2 * L + 0] = 0.5f;
        expect_error(rig.set(outside), ErrorCode::kInvalidParam, "output_matrix", "gain");
    }
    OutputMatrixParams wrong_count = mix;
    wrong_count.axis_count = static_cast<uint8_t>(N == 3 ? 2 : N + 1);
    expect_error(rig.set(wrong_count), ErrorCode::kInvalidParam, "output_matrix", "axis_count");
    EXPECT_EQ(rig.template get<OutputMatrixParams>(), mix);

    // Armed: a changed matrix is refused, the one in effect stays.
    ASSERT_EQ(rig.request(Arm{}).type(), MsgType::kAck);
    rig.tick();
    OutputMatrixParams other = identity;
    expect_error(rig.set(other), ErrorCode::kArmed, "axes", "output_matrix");
    InputMatrixParams in2 = in;
    in2.offset_um[0] = -1.0f;
    expect_error(rig.set(in2), ErrorCode::kArmed, "axes", "input_matrix");
    // The same matrix again changes nothing and is acknowledged.
    EXPECT_EQ(rig.set(mix).type(), MsgType::kAck);
    rig.tick(2);
    EXPECT_EQ(rig.template get<OutputMatrixParams>(), mix);
    EXPECT_EQ(rig.template get<InputMatrixParams>(), in);
    EXPECT_EQ(rig.multi->output_matrix().m[0][0], 0.98f);
    EXPECT_EQ(rig.multi->input_matrix().offset_um[0], in.offset_um[0]);  // in2 refused
}

// Channels of different axes in one record: every frame holds, per channel,
// the signal of its axis at the frame's tick, bit for bit.
TYPED_TEST(DeviceAxes, RecorderChannelsOfDifferentAxes) {
    using T = typename TypeParam::Sample;
    constexpr int N = TypeParam::kAxes;
    AxesRig<T, N> rig;
    rig.configure_reference();
    const uint8_t wave_axis = static_cast<uint8_t>(N - 1);
    TrajectoryParams t;
    t.waveform = Waveform::kSine;
    t.amplitude_um = 3.0f;
    t.frequency_Hz = 500.0f;
    ASSERT_EQ(rig.set(t, wave_axis).type(), MsgType::kAck);

    RecorderParams rp = rig.template get<RecorderParams>();
    ASSERT_EQ(rp.channel_count, 8);
    const std::array<uint8_t, 8> signals = {0, 1, 3, 0, 1, 3, 2, 7};
    for (std::size_t c = 0; c < 8; ++c) {
        rp.channels[c] = signals[c];
        rp.axes[c] = static_cast<uint8_t>((c / 3) % N);
    }
    rp.mode = RecordMode::kSingleShot;
    rp.trigger = TriggerMode::kImmediate;
    rp.length = 200;
    ASSERT_EQ(rig.set(rp).type(), MsgType::kAck);
    EXPECT_EQ(rig.template get<RecorderParams>(), rp);
    // An axis beyond the count in a channel: refused, naming the channel.
    RecorderParams bad = rp;
    bad.axes[5] = static_cast<uint8_t>(N);
    if (N < 3) {
        const Reply r = rig.set(bad);
        expect_error(r, ErrorCode::kInvalidParam, "recorder", "axes");
        EXPECT_EQ(r.as<ErrorReply>().index, 5);
    }
    EXPECT_EQ(rig.template get<RecorderParams>(), rp);

    StartWave w{StartWave::kArmLoop | StartWave::kArmRecorder};
    w.axis = wave_axis;
    ASSERT_EQ(rig.request(w).type(), MsgType::kAck);
    std::vector<std::array<TickSignals<T>, N>> seen;
    const uint32_t first = rig.multi->tick_count();
    for (int k = 0; k < 200; ++k) {
        rig.tick();
        std::array<TickSignals<T>, N> s{};
        for (int a = 0; a < N; ++a) s[a] = rig.multi->axis(a).last();
        seen.push_back(s);
    }
    const std::vector<LogBlock> blocks = rig.drain_log();
    std::size_t frames = 0;
    for (const LogBlock& b : blocks) {
        ASSERT_EQ(b.channel_count, 8);
        for (std::size_t c = 0; c < 8; ++c) EXPECT_EQ(b.channels[c], rp.axes[c] * kSignalCount + rp.channels[c]);
        for (std::size_t f = 0; f < b.frame_count; ++f, ++frames) {
            const uint32_t k = b.first_tick + static_cast<uint32_t>(f) * b.tick_stride - first;
            ASSERT_LT(k, seen.size());
            for (std::size_t c = 0; c < 8; ++c)
                EXPECT_EQ(b.samples[f * 8 + c], bits(signal_of(seen[k][rp.axes[c]], rp.channels[c])))
                    << "frame " << k << " channel " << c;
        }
    }
    EXPECT_EQ(frames, 200u);
    // The wave moved its axis's reference, and only its.
    EXPECT_NE(bits(seen[50][wave_axis].r), bits(T{}));
    if (N > 1) {
        EXPECT_EQ(bits(seen[50][0].r), bits(T{}));
    }
}

TYPED_TEST(DeviceAxes, AStoredSetHoldsEveryAxisAndTheMatrices) {
    constexpr int N = TypeParam::kAxes;
    using T = typename TypeParam::Sample;
    storage::MemoryStorage mem;
    DeviceHooks hooks;
    hooks.storage = &mem;
    std::array<LimitsParams, N> limits{};
    OutputMatrixParams mix{static_cast<uint8_t>(N)};
    mix.gain[0] = 0.97f;
    {
        AxesRig<T, N> rig(hooks);
        rig.configure_reference();
        ASSERT_EQ(rig.set(mix).type(), MsgType::kAck);
        rig.tick();
        for (uint8_t a = 0; a < N; ++a) limits[a] = rig.template get<LimitsParams>(a);
        ASSERT_EQ(rig.request(Save{}).type(), MsgType::kAck);
    }
    AxesRig<T, N> booted(hooks);
    EXPECT_EQ(booted.device->boot_from_storage(), StorageState::kApplied);
    booted.tick();
    for (uint8_t a = 0; a < N; ++a) EXPECT_EQ(booted.template get<LimitsParams>(a), limits[a]) << int{a};
    EXPECT_EQ(booted.template get<OutputMatrixParams>(), mix);
    EXPECT_EQ(booted.multi->output_matrix().m[0][0], 0.97f);

    // A board of another axis count refuses the set, naming it.
    if constexpr (N > 1) {
        AxesRig<T, N - 1> fewer(hooks);
        EXPECT_EQ(fewer.device->boot_from_storage(), StorageState::kRejected);
        const StatusReply st = fewer.request(GetStatus{}).template as<StatusReply>();
        EXPECT_STREQ(st.storage_field.data(), "axis_count");
    }
}

// One axis over a MultiAxisPipeline is today's device over a Pipeline: the
// same requests give the same log, bit for bit.
TEST(DeviceAxesOne, OneAxisLogsExactlyWhatASinglePipelineDeviceLogs) {
    using T = float;
    AxesRig<T, 1> multi;
    using SingleDevice = Device<T, 1024, 8, 1024, 1024, 1024>;
    typename SingleDevice::PipelineType pipe(reference::setup());
    SingleDevice single(pipe);
    std::vector<std::vector<uint8_t>> single_frames;
    auto single_sink = [&](std::span<const uint8_t> f) { single_frames.emplace_back(f.begin(), f.end()); };
    uint16_t seq = 0;
    auto both = [&](const auto& m) {
        std::vector<uint8_t> f(kMaxFrameSize);
        f.resize(encode_message(m, ++seq, f));
        single.receive(f, single_sink);
        (void)multi.request(m);
    };
    const PipelineParams p = reference::params(true, true, false);
    both(SetParams<LimitsParams>{LimitsParams{p.limits}});
    pipe.tick(0.0f);
    multi.tick();
    both(SetParams<FeedforwardParams>{FeedforwardParams{p.feedforward, p.pi, p.dahl}});
    pipe.tick(0.0f);
    multi.tick();
    both(SetParams<FeedbackParams>{FeedbackParams{p.feedback, p.sos_count, p.sos, p.pid}});
    pipe.tick(0.0f);
    multi.tick();
    TrajectoryParams t;
    t.waveform = Waveform::kTriangle;
    t.amplitude_um = 5.0f;
    t.frequency_Hz = 200.0f;
    both(SetParams<TrajectoryParams>{t});
    RecorderParams rp = multi.get<RecorderParams>();
    rp.channels = {0, 1, 2, 3, 4, 5, 6, 7};
    rp.mode = RecordMode::kSingleShot;
    rp.length = 300;
    both(SetParams<RecorderParams>{rp});
    both(StartWave{StartWave::kArmLoop | StartWave::kArmRecorder});
    // A plant in the loop: y follows u through the reference plant on both.
    HammersteinPlant a, b;
    ASSERT_TRUE(a.configure(reference::plant()).ok());
    ASSERT_TRUE(b.configure(reference::plant()).ok());
    float ya = 0.0f, yb = 0.0f;
    for (int k = 0; k < 300; ++k) {
        single.on_tick();
        ya = static_cast<float>(a.step(pipe.tick(ya)));
        multi.device->on_tick();
        yb = static_cast<float>(b.step(multi.multi->tick({yb})[0]));
    }
    single_frames.clear();
    while (single.poll_log(single_sink)) {
    }
    const std::vector<LogBlock> mb = multi.drain_log();
    ASSERT_EQ(single_frames.size(), mb.size());
    std::size_t checked = 0;
    for (std::size_t i = 0; i < mb.size(); ++i) {
        FrameDecoder d;
        LogBlock sb;
        d.feed(single_frames[i], [&](std::span<const uint8_t> payload) {
            ASSERT_EQ(decode_body(payload.subspan(kHeaderSize), sb), DecodeResult::kOk);
        });
        EXPECT_EQ(sb, mb[i]);
        checked += sb.frame_count;
    }
    EXPECT_EQ(checked, 300u);
}

namespace {

// A small raster the reference stage's setup can run quickly: 4 lines of 8
// pixels at 2 kHz lines (the loop rate's ticks a pixel a whole number).
ScanConfig small_raster() {
    ScanConfig c;
    c.pattern = ScanPattern::kRaster;
    c.centre_x_um = 1.0f;
    c.centre_y_um = -0.5f;
    c.size_x_um = 2.0f;
    c.size_y_um = 1.0f;
    c.pixels_per_line = 8;
    c.lines_per_frame = 4;
    c.line_rate_Hz = 500.0f;
    c.turnaround_s = 2e-4f;
    c.frames = 1;
    return c;
}

}  // namespace

// StartScan on a board of axes: x and y follow a ScanFeed run alone from the
// stage's readings (bit for bit), the recorder's sync channel carries its
// events on the same ticks, the status follows the scan to its end, and the
// sync word is 0 after it. StopWave stops a scan where it is.
TYPED_TEST(DeviceAxes, ScanDrivesTheAxesWithItsSyncWord) {
    using T = typename TypeParam::Sample;
    constexpr int N = TypeParam::kAxes;
    AxesRig<T, N> rig;
    rig.configure_reference();
    StartScan m{StartWave::kArmLoop | StartWave::kArmRecorder};
    m.config = small_raster();
    if (N == 1) {
        expect_error(rig.request(m), ErrorCode::kUnsupported, "scan", "pattern");
        RecorderParams rp = rig.template get<RecorderParams>();
        rp.channels[2] = params::kSyncChannel;
        expect_error(rig.set(rp), ErrorCode::kInvalidParam, "recorder", "channels");
        return;
    }
    EXPECT_NE(rig.device->make_hello().capabilities & cap::kScan, 0u);
    RecorderParams rp = rig.template get<RecorderParams>();
    rp.mode = RecordMode::kContinuous;
    rp.channels[0] = signal_index(SignalId::kR);
    rp.axes[0] = 0;
    rp.channels[1] = signal_index(SignalId::kR);
    rp.axes[1] = 1;
    rp.channels[2] = params::kSyncChannel;
    rp.axes[2] = 1;
    expect_error(rig.set(rp), ErrorCode::kInvalidParam, "recorder", "axes");
    rp.axes[2] = 0;
    ASSERT_EQ(rig.set(rp).type(), MsgType::kAck);
    EXPECT_EQ(rig.template get<RecorderParams>().channels[2], params::kSyncChannel);

    // Refused, naming the field, and nothing changes.
    StartScan bad = m;
    bad.config.pixels_per_line = 0;
    expect_error(rig.request(bad), ErrorCode::kInvalidParam, "scan", "pixels_per_line");
    rig.tick();
    EXPECT_FALSE(rig.multi->axis(0).armed());
    EXPECT_EQ(rig.device->make_status().scan_state, 0u);

    ASSERT_EQ(rig.request(m).type(), MsgType::kAck);
    // The reference: the same feed from the stage's readings (zero).
    const SignalScale pos = rig.multi->axis(0).setup().position;
    ScanFeed<T> feed(pos, pos, pos, rig.multi->axis(0).setup().rate_Hz);
    ScanConfig c = m.config;
    c.sample_rate_Hz = rig.multi->axis(0).setup().rate_Hz;
    ASSERT_TRUE(feed.start(c, T{}, T{}, T{}).ok());
    std::vector<ScanPoint<T>> expected;
    while (!feed.done()) expected.push_back(feed.step());
    ASSERT_GT(feed.approach_ticks(), 0u);

    // A running scan refuses waves, streams and another scan.
    TrajectoryParams t;
    t.amplitude_um = 1.0f;
    t.frequency_Hz = 10.0f;
    ASSERT_EQ(rig.set(t, 0).type(), MsgType::kAck);
    rig.tick();
    EXPECT_EQ(rig.device->make_status().scan_state, static_cast<uint8_t>(ScanState::kApproaching));
    expect_error(rig.request(StartWave{}), ErrorCode::kBusy, "trajectory", "waveform");
    expect_error(rig.request(m), ErrorCode::kBusy, "scan", "pattern");
    // Ticks in short runs, the log drained between them (the recorder holds 1024 frames).
    std::vector<LogBlock> log;
    auto run = [&](std::size_t ticks) {
        for (std::size_t i = 0; i < ticks; ++i) {
            rig.tick();
            if (i % 64 == 63)
                for (const LogBlock& b : rig.drain_log()) log.push_back(b);
        }
        for (const LogBlock& b : rig.drain_log()) log.push_back(b);
    };
    run(expected.size() + 1);
    const StatusReply st = rig.device->make_status();
    EXPECT_EQ(st.scan_state, static_cast<uint8_t>(ScanState::kEnded));
    EXPECT_EQ(st.scan_approach_ticks, feed.approach_ticks());
    EXPECT_EQ(st.scan_ticks, expected.size());
    EXPECT_EQ(st.scan_frames_completed, 1u);
    run(2);
    ASSERT_EQ(rig.request(RecorderStop{}).type(), MsgType::kAck);
    for (const LogBlock& b : rig.drain_log()) log.push_back(b);

    std::size_t k = 0, events = 0;
    for (const LogBlock& b : log) {
        EXPECT_EQ(b.channels[2], kBoardSyncSignal);
        for (std::size_t f = 0; f < b.frame_count; ++f, ++k) {
            const uint32_t* s = &b.samples[f * 8];
            const bool in_scan = k < expected.size();
            const uint32_t sync = in_scan ? expected[k].sync : 0u;
            if (in_scan) {
                ASSERT_EQ(s[0], bits(expected[k].x)) << k;
                ASSERT_EQ(s[1], bits(expected[k].y)) << k;
            }
            if constexpr (std::is_same_v<T, float>) ASSERT_EQ(s[2], std::bit_cast<uint32_t>(static_cast<float>(sync))) << k;
            else ASSERT_EQ(s[2], sync) << k;
            events += sync != 0;
        }
    }
    EXPECT_EQ(k, expected.size() + 4);  // the scan, then three ticks after it
    EXPECT_GE(events, 4u * 8u);  // every pixel clock at least

    // StopWave stops a scan where it is: the setpoints hold.
    StartScan again{};
    again.config = small_raster();
    again.config.frames = 0;
    ASSERT_EQ(rig.request(again).type(), MsgType::kAck);
    rig.tick(static_cast<int>(feed.approach_ticks()) + 50);
    ASSERT_EQ(rig.request(StopWave{}).type(), MsgType::kAck);
    rig.tick(2);
    const T held = rig.multi->axis(0).setpoint();
    rig.tick(20);
    EXPECT_EQ(bits(rig.multi->axis(0).setpoint()), bits(held));
    EXPECT_EQ(rig.device->make_status().scan_state, static_cast<uint8_t>(ScanState::kEnded));
}

// A pattern, slow axis, fast axis or spiral mode beyond its enum is malformed.
TEST(DeviceScanMessage, EnumsBeyondTheirRangeAreMalformed) {
    StartScan m;
    m.config.pattern = static_cast<ScanPattern>(4);
    std::array<uint8_t, kMaxBody> buf{};
    Writer w(buf);
    m.write(w);
    Reader r(std::span<const uint8_t>(buf.data(), w.size()));
    StartScan back;
    back.read(r);
    EXPECT_TRUE(r.bad_value());
    m.config.pattern = ScanPattern::kCycloid;
    Writer w2(buf);
    m.write(w2);
    Reader r2(std::span<const uint8_t>(buf.data(), w2.size()));
    back.read(r2);
    EXPECT_TRUE(r2.complete());
    EXPECT_EQ(back, m);
}
