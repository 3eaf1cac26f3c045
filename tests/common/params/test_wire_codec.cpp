// The wire layouts derived from the declarations (params/wire_codec.hpp),
// against layouts written out by hand from the protocol's tables: the
// field order, types and counts of each group, byte for byte, and the sizes
// the protocol states (docs/protocol.md, section 3: feedforward 121 + 8 per
// operator, feedback 188, rc 59, limits 18, trajectory 33 + 4 per table
// point, recorder 39, with the group id and axis bytes).
#include <gtest/gtest.h>

#include <array>
#include <bit>
#include <cstdint>
#include <vector>

#include "piezoloop/params/wire_codec.hpp"

using namespace piezoloop;
using namespace piezoloop::params;

namespace {

// Little-endian bytes, written by hand.
struct Bytes {
    std::vector<uint8_t> b;
    void u8(unsigned v) { b.push_back(static_cast<uint8_t>(v)); }
    void u16(unsigned v) { for (int i = 0; i < 2; ++i) u8((v >> (8 * i)) & 0xFFu); }
    void u32(uint32_t v) { for (int i = 0; i < 4; ++i) u8((v >> (8 * i)) & 0xFFu); }
    void f32(float v) { u32(std::bit_cast<uint32_t>(v)); }
    void f64(double v) {
        const uint64_t x = std::bit_cast<uint64_t>(v);
        for (int i = 0; i < 8; ++i) u8(static_cast<unsigned>((x >> (8 * i)) & 0xFFu));
    }
};

template <class G>
std::vector<uint8_t> encode(const G& g) {
    std::array<uint8_t, 1024> buf{};
    link::Writer w(buf);
    write_group(w, g);
    EXPECT_TRUE(w.ok());
    return {buf.begin(), buf.begin() + static_cast<std::ptrdiff_t>(w.size())};
}

TEST(ParamsWireCodec, FeedforwardByHand) {
    FeedforwardParams g;
    g.kind = FeedforwardKind::kPiInverse;
    g.pi.input_gain = 2.0f;
    g.pi.input_offset = -0.5f;
    g.pi.p0 = 0.25f;
    g.pi.count = 2;
    g.pi.thresholds = {0.0f, 1.5f};
    g.pi.weights = {0.75f, -0.125f};
    g.pi.dead_zones = 1;
    g.pi.dead_zone_thresholds = {-3.0f};
    g.pi.dead_zone_weights = {0.5f};
    g.dahl = {1.0f, 2.0f, 3.0f, 4.0f, 5.0f, 6.0f};
    Bytes e;
    e.u8(1);
    e.f32(2.0f); e.f32(-0.5f); e.f32(0.25f);
    e.u8(2);
    e.f32(0.0f); e.f32(1.5f);      // thresholds[count]
    e.f32(0.75f); e.f32(-0.125f);  // weights[count]
    e.u8(1);
    e.f32(-3.0f);                  // dead_zone_thresholds[dead_zones]
    e.f32(0.5f);                   // dead_zone_weights[dead_zones]
    for (float d : {1.0f, 2.0f, 3.0f, 4.0f, 5.0f, 6.0f}) e.f32(d);
    e.u8(0);  // prefilter_count; both sections always travel (the default, b0 = 1)
    for (int i = 0; i < 2; ++i)
        for (double d : {1.0, 0.0, 0.0, 0.0, 0.0}) e.f64(d);
    EXPECT_EQ(encode(g), e.b);
    // With the group id and the axis: 122 fixed, 8 per play, 8 per dead zone.
    EXPECT_EQ(e.b.size() + 2, 122u + 8u * 2u + 8u * 1u);
}

TEST(ParamsWireCodec, FeedbackAlwaysCarriesFourSections) {
    FeedbackParams g;
    g.kind = FeedbackKind::kSos;
    g.sos_count = 1;
    g.sos[0] = {0.5, 0.25, 0.125, -1.5, 0.5625};
    g.pid = {1.0f, 2.0f, 3.0f, 4.0f, -5.0f, 6.0f};
    Bytes e;
    e.u8(1);
    e.u8(1);
    for (const SosSection& s : g.sos) { e.f64(s.b0); e.f64(s.b1); e.f64(s.b2); e.f64(s.a1); e.f64(s.a2); }
    for (float p : {1.0f, 2.0f, 3.0f, 4.0f, -5.0f, 6.0f}) e.f32(p);
    EXPECT_EQ(encode(g), e.b);
    EXPECT_EQ(e.b.size() + 1, 187u);
}

TEST(ParamsWireCodec, RcLimitsTrajectoryRecorderByHand) {
    RepetitiveParams rc;
    rc.enabled = true;
    Bytes e;
    e.u8(1);
    e.u32(100); e.u32(6); e.u32(0);
    e.f32(0.8f);
    e.f64(0.0); e.f64(0.3558); e.f64(0.0); e.f64(-0.6442); e.f64(0.0);
    EXPECT_EQ(encode(rc), e.b);
    EXPECT_EQ(e.b.size() + 1, 58u);

    LimitsParams l;
    l.limits = {-1.0f, 9.0f, 1e5f, 0.5f};
    Bytes el;
    for (float v : {-1.0f, 9.0f, 1e5f, 0.5f}) el.f32(v);
    EXPECT_EQ(encode(l), el.b);
    EXPECT_EQ(el.b.size() + 1, 17u);

    TrajectoryParams t;
    t.waveform = Waveform::kSteps;
    t.amplitude_um = 3.0f;
    t.cycles = 7;
    t.table_count = 3;
    t.table = {-1.0f, 0.0f, 1.0f};
    Bytes et;
    et.u8(4);
    et.f32(3.0f); et.f32(0.0f); et.f32(1.0f); et.u32(7);
    et.f32(0.0f); et.f32(0.1f); et.f32(0.5f);
    et.u16(3);
    et.f32(-1.0f); et.f32(0.0f); et.f32(1.0f);
    EXPECT_EQ(encode(t), et.b);
    EXPECT_EQ(et.b.size() + 1, 32u + 4u * 3u);

    RecorderParams r;
    r.channel_count = 4;
    r.channels = {0, 1, 2, 3};
    r.decimation = 5;
    r.trigger = TriggerMode::kRising;
    r.trigger_signal = 1;
    r.trigger_level = 2.5f;
    r.pre_trigger = 10;
    r.length = 200;
    r.axes = {0, 1, 2, 0, 0, 0, 0, 0};
    r.trigger_axis = 2;
    Bytes er;
    er.u8(4);
    for (unsigned c : {0u, 1u, 2u, 3u, 0u, 0u, 0u, 0u}) er.u8(c);  // all eight slots travel
    for (unsigned a : {0u, 1u, 2u, 0u, 0u, 0u, 0u, 0u}) er.u8(a);  // and their axes
    er.u32(5);
    er.u8(1); er.u8(1); er.u8(1); er.u8(2);  // continuous, rising, y of axis 2
    er.f32(2.5f); er.u32(10); er.u32(200);
    EXPECT_EQ(encode(r), er.b);
    EXPECT_EQ(er.b.size() + 2, 39u);
}

TEST(ParamsWireCodec, SizesFromTheDeclarations) {
    EXPECT_EQ(layout_size<FeedforwardParams>().fixed + 2, 122u);
    EXPECT_EQ(layout_size<FeedforwardParams>().per_count(), 16u);  // 8 per play and 8 per dead zone
    EXPECT_EQ(layout_size<FeedbackParams>().fixed + 2, 188u);
    EXPECT_EQ(layout_size<FeedbackParams>().per_count(), 0u);
    EXPECT_EQ(layout_size<TrajectoryParams>().fixed + 2, 33u);
    EXPECT_EQ(layout_size<TrajectoryParams>().per_count(), 4u);
    EXPECT_EQ(layout_size<RecorderParams>().fixed + 2, 39u);
    // The matrices: the axis count, 3 x 3 gains (and 3 offsets), all travelling.
    EXPECT_EQ(layout_size<InputMatrixParams>().fixed + 2, 2u + 1u + 36u + 12u);
    EXPECT_EQ(layout_size<OutputMatrixParams>().fixed + 2, 2u + 1u + 36u);
}

TEST(ParamsWireCodec, ReadBackAndCountsBeyondTheirArrays) {
    FeedforwardParams g;
    g.pi.count = 3;
    g.pi.thresholds = {0.0f, 1.0f, 2.0f};
    g.pi.weights = {1.0f, 0.5f, 0.25f};
    const std::vector<uint8_t> bytes = encode(g);
    FeedforwardParams back;
    back.pi.thresholds.fill(9.0f);  // stale values beyond the count are cleared
    link::Reader r(bytes);
    read_group(r, back);
    EXPECT_TRUE(r.complete());
    EXPECT_EQ(back, g);

    std::vector<uint8_t> bad = bytes;
    bad[13] = 17;  // the operator count, after kind and three floats: one more than the array holds
    FeedforwardParams out;
    link::Reader rb(bad);
    read_group(rb, out);
    EXPECT_TRUE(rb.bad_value());

    FeedbackParams fb;
    std::vector<uint8_t> fbytes = encode(fb);
    fbytes[1] = 5;  // sos_count beyond the four sections
    link::Reader rf(fbytes);
    read_group(rf, fb);
    EXPECT_TRUE(rf.bad_value());
}

}  // namespace
