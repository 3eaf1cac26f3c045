// The emulated boards' profile blob (and the axes blob beside it for a
// stage of coupled axes): round trip, the layout at fixed offsets
// (counted here from the documented field list, independently of the
// encoder), and every rejection -- which names the field and leaves the
// output untouched. Exact comparisons throughout: the blob carries bit
// patterns.
#include <gtest/gtest.h>

#include <array>
#include <bit>
#include <cmath>
#include <cstring>
#include <limits>
#include <vector>

#include "piezoloop/axes/emulation_axes_profile.hpp"
#include "piezoloop/emulation_profile.hpp"
#include "piezoloop/link/crc32.hpp"
#include "piezoloop/reference_stage.hpp"

using namespace piezoloop;

namespace {

// The reference stage with every part switched on, so each field carries a
// distinct non-default value.
EmulationProfile sample_profile() {
    EmulationProfile p;
    p.loop_rate_Hz = 50000;
    p.position_full_scale_um = 80.0f;
    p.voltage_full_scale_V = 150.0f;
    StageConfig& s = p.stage;
    s.rate_Hz = 50000.0f;
    s.dac = ConverterConfig{16, -10.0f, 10.0f};
    s.amplifier.gain = 10.0f;
    s.amplifier.input_min_V = -10.0f;
    s.amplifier.input_max_V = 10.0f;
    s.amplifier.output_min_V = -20.0f;
    s.amplifier.output_max_V = 120.0f;
    s.amplifier.bandwidth_Hz = 3000.0f;
    s.plant = reference::plant();
    s.plant.dahl = kAhmad2020Dahl;
    s.plant.linear_gain_um_per_V = 0.75f;
    s.sensor.gain = 0.1f;
    s.sensor.bandwidth_Hz = 10000.0f;
    s.sensor.noise_rms = 0.002f;
    s.sensor.seed = 12345;
    s.adc = ConverterConfig{18, -10.0f, 10.0f};
    s.sensor.offset_um = 0.3f;
    s.sensor.gain_error = -0.015f;
    s.sensor.mains.frequency_Hz = 60.0f;
    s.sensor.mains.count = 3;
    s.sensor.mains.amplitudes_um = {0.005f, 0.003f, 0.002f};
    s.plant.creep = {2.0f, 0.01f, 100.0f};
    s.plant.drift_um_per_s = 0.05f;
    s.plant.output_map.count = 2;
    s.plant.output_map.thresholds_um = {5.0f, 12.0f};
    s.plant.output_map.weights = {-0.1f, -0.25f};
    return p;
}

std::vector<uint8_t> encode(const EmulationProfile& p) {
    std::vector<uint8_t> b(kEmulationProfileMaxBytes, 0xA5);
    const std::size_t n = encode_profile(p, b);
    EXPECT_EQ(n, kEmulationProfileHeaderBytes + kEmulationProfileBodyBytes);
    b.resize(n);
    return b;
}

uint32_t le32(const std::vector<uint8_t>& b, std::size_t at) {
    return uint32_t{b[at]} | uint32_t{b[at + 1]} << 8 | uint32_t{b[at + 2]} << 16 | uint32_t{b[at + 3]} << 24;
}
void put32(std::vector<uint8_t>& b, std::size_t at, uint32_t v) {
    ASSERT_LE(at + 4, b.size());
    for (std::size_t i = 0; i < 4; ++i) b.at(at + i) = static_cast<uint8_t>(v >> (8 * i));
}
// Re-seals the CRC after a test edited the body.
void reseal(std::vector<uint8_t>& b) {
    put32(b, 12, link::crc32(std::span<const uint8_t>(b).subspan(16, kEmulationProfileBodyBytes)));
}

bool same(const EmulationProfile& a, const EmulationProfile& b) { return encode(a) == encode(b); }

}  // namespace

TEST(EmulationProfile, RoundTripIsExact) {
    const EmulationProfile p = sample_profile();
    ASSERT_TRUE(validate(p).ok()) << validate(p).field;
    const auto b = encode(p);
    EmulationProfile q;
    const Status s = decode_profile(b, q);
    ASSERT_TRUE(s.ok()) << s.field << ": " << s.message;
    EXPECT_EQ(q.loop_rate_Hz, p.loop_rate_Hz);
    EXPECT_EQ(q.position_full_scale_um, p.position_full_scale_um);
    EXPECT_EQ(q.voltage_full_scale_V, p.voltage_full_scale_V);
    EXPECT_EQ(q.stage.dac, p.stage.dac);
    EXPECT_EQ(q.stage.adc, p.stage.adc);
    EXPECT_EQ(q.stage.plant.pi, p.stage.plant.pi);
    EXPECT_EQ(q.stage.plant.dahl, p.stage.plant.dahl);
    EXPECT_EQ(q.stage.plant.dynamics, p.stage.plant.dynamics);
    EXPECT_EQ(q.stage.plant.sections, p.stage.plant.sections);
    EXPECT_EQ(q.stage.plant.hysteresis, p.stage.plant.hysteresis);
    EXPECT_EQ(q.stage.plant.linear_gain_um_per_V, p.stage.plant.linear_gain_um_per_V);
    EXPECT_EQ(q.stage.plant.output_map.count, 2);
    EXPECT_EQ(q.stage.plant.output_map.thresholds_um, p.stage.plant.output_map.thresholds_um);
    EXPECT_EQ(q.stage.plant.output_map.weights, p.stage.plant.output_map.weights);
    EXPECT_EQ(q.stage.sensor.seed, p.stage.sensor.seed);
    EXPECT_EQ(q.stage.sensor.noise_rms, p.stage.sensor.noise_rms);
    EXPECT_EQ(q.stage.amplifier.output_max_V, p.stage.amplifier.output_max_V);
    EXPECT_EQ(encode(q), b);
    // Decoding from a larger area (the whole reserved RAM) reads the same.
    std::vector<uint8_t> area(kEmulationProfileMaxBytes, 0xEE);
    std::copy(b.begin(), b.end(), area.begin());
    EmulationProfile r;
    ASSERT_TRUE(decode_profile(area, r).ok());
    EXPECT_TRUE(same(r, p));
    EXPECT_TRUE(profile_present(area));
}

TEST(EmulationProfile, LayoutAtDocumentedOffsets) {
    // Body size summed from the header's field list: rate + 2 full scales
    // (12), stage rate (4), dac (12), amplifier 6 f32 (24), plant: kind (1),
    // pi 3 f32 + count + 2 x 16 f32 (141), dahl 6 f32 (24), linear gain (4),
    // sections (1), 6 x 5 f64 (240), sensor (16), adc (12); sensor offset,
    // gain error, mains frequency, count, 8 amplitudes (45); creep 3 f32
    // and drift (16); the output map's count, 8 thresholds, 8 weights (65).
    constexpr std::size_t kSum =
        12 + 4 + 12 + 24 + 1 + (12 + 1 + 128) + 24 + 4 + 1 + 240 + 16 + 12 + (12 + 1 + 32) + 16 + 65;
    static_assert(kSum == kEmulationProfileBodyBytes);
    const EmulationProfile p = sample_profile();
    const auto b = encode(p);
    EXPECT_EQ(b[0], 'P');
    EXPECT_EQ(b[1], 'Z');
    EXPECT_EQ(b[2], 'E');
    EXPECT_EQ(b[3], 'M');
    EXPECT_EQ(b[4] | b[5] << 8, 3);
    EXPECT_EQ(b[6] | b[7] << 8, 0);
    EXPECT_EQ(le32(b, 8), kSum);
    EXPECT_EQ(le32(b, 16), 50000u);
    EXPECT_EQ(le32(b, 20), std::bit_cast<uint32_t>(80.0f));
    EXPECT_EQ(le32(b, 28), std::bit_cast<uint32_t>(50000.0f));  // stage.rate_Hz
    EXPECT_EQ(le32(b, 32), 16u);                                // dac.bits
    EXPECT_EQ(b[16 + 52], static_cast<uint8_t>(HysteresisKind::kPi));
    // The last fields: the output map's 8 weights (the 3rd to 8th are 0),
    // 8 thresholds, its count.
    const std::size_t map = b.size() - 65;
    EXPECT_EQ(b[map], 2);
    EXPECT_EQ(le32(b, map + 1), std::bit_cast<uint32_t>(5.0f));
    EXPECT_EQ(le32(b, map + 5), std::bit_cast<uint32_t>(12.0f));
    EXPECT_EQ(le32(b, map + 33), std::bit_cast<uint32_t>(-0.1f));
    EXPECT_EQ(le32(b, map + 37), std::bit_cast<uint32_t>(-0.25f));
    EXPECT_EQ(le32(b, map + 41), 0u);
    // Before it (version 2's end): drift, creep to_s, from_s, percent_per_decade.
    const std::size_t v2_end = map;
    EXPECT_EQ(le32(b, v2_end - 4), std::bit_cast<uint32_t>(0.05f));
    EXPECT_EQ(le32(b, v2_end - 8), std::bit_cast<uint32_t>(100.0f));
    EXPECT_EQ(le32(b, v2_end - 16), std::bit_cast<uint32_t>(2.0f));
    // Before them the mains: 8 amplitudes (the 4th to 8th are 0), the count.
    EXPECT_EQ(le32(b, v2_end - 48), std::bit_cast<uint32_t>(0.005f));
    EXPECT_EQ(le32(b, v2_end - 36), 0u);
    EXPECT_EQ(b[v2_end - 49], 3);
    EXPECT_EQ(le32(b, v2_end - 53), std::bit_cast<uint32_t>(60.0f));
    EXPECT_EQ(le32(b, v2_end - 57), std::bit_cast<uint32_t>(-0.015f));
    EXPECT_EQ(le32(b, v2_end - 61), std::bit_cast<uint32_t>(0.3f));
    // Then adc.max, adc.bits and the sensor seed as in version 1.
    const std::size_t v1_end = v2_end - 61;
    EXPECT_EQ(le32(b, v1_end - 4), std::bit_cast<uint32_t>(10.0f));
    EXPECT_EQ(le32(b, v1_end - 12), 18u);  // adc.bits
    EXPECT_EQ(le32(b, v1_end - 16), 12345u);
}

TEST(EmulationProfile, ReferenceStageIsValidAndTheAddressIsOutsideTheImages) {
    EmulationProfile p;
    p.stage.plant = reference::plant();
    EXPECT_TRUE(validate(p).ok());
    // Last KiB of the 4 MiB SSRAM1, aligned to the reserved size.
    EXPECT_EQ(kEmulationProfileAddress + kEmulationProfileMaxBytes, 0x00400000u);
    EXPECT_EQ(kEmulationProfileAddress % kEmulationProfileMaxBytes, 0u);
    std::array<uint8_t, 4> small{};
    EXPECT_EQ(encode_profile(p, small), 0u);
}

namespace {
struct Case {
    const char* name;
    void (*edit)(EmulationProfile&);
    const char* group;
    const char* field;
};
}  // namespace

TEST(EmulationProfile, EveryValueRejectionNamesItsFieldAndLeavesOutUntouched) {
    const float nan = std::numeric_limits<float>::quiet_NaN();
    static float s_nan;
    s_nan = nan;
    const Case cases[] = {
        {"rate 0", [](EmulationProfile& p) { p.loop_rate_Hz = 0; }, nullptr, "loop_rate_Hz"},
        {"rate above 200 kHz", [](EmulationProfile& p) { p.loop_rate_Hz = 250000; p.stage.rate_Hz = 250000.0f; }, nullptr, "loop_rate_Hz"},
        {"rate not dividing 25 MHz", [](EmulationProfile& p) { p.loop_rate_Hz = 30000; p.stage.rate_Hz = 30000.0f; }, nullptr, "loop_rate_Hz"},
        {"position fs 0", [](EmulationProfile& p) { p.position_full_scale_um = 0.0f; }, nullptr, "position_full_scale_um"},
        {"position fs NaN", [](EmulationProfile& p) { p.position_full_scale_um = s_nan; }, nullptr, "position_full_scale_um"},
        {"voltage fs < 0", [](EmulationProfile& p) { p.voltage_full_scale_V = -1.0f; }, nullptr, "voltage_full_scale_V"},
        {"voltage fs inf", [](EmulationProfile& p) { p.voltage_full_scale_V = std::numeric_limits<float>::infinity(); }, nullptr, "voltage_full_scale_V"},
        {"stage rate differs", [](EmulationProfile& p) { p.stage.rate_Hz = 100000.0f; }, "stage", "rate_Hz"},
        {"dac bits 1", [](EmulationProfile& p) { p.stage.dac.bits = 1; }, "dac", "bits"},
        {"adc range", [](EmulationProfile& p) { p.stage.adc.max = p.stage.adc.min; }, "adc", "max"},
        {"amp gain NaN", [](EmulationProfile& p) { p.stage.amplifier.gain = s_nan; }, "amplifier", "gain"},
        {"amp input range", [](EmulationProfile& p) { p.stage.amplifier.input_max_V = -20.0f; }, "amplifier", "input_max_V"},
        {"amp output range", [](EmulationProfile& p) { p.stage.amplifier.output_max_V = -30.0f; }, "amplifier", "output_max_V"},
        {"amp bandwidth >= rate/2", [](EmulationProfile& p) { p.stage.amplifier.bandwidth_Hz = 25000.0f; }, "amplifier", "bandwidth_Hz"},
        {"sensor bandwidth < 0", [](EmulationProfile& p) { p.stage.sensor.bandwidth_Hz = -1.0f; }, "sensor", "bandwidth_Hz"},
        {"sensor gain 0", [](EmulationProfile& p) { p.stage.sensor.gain = 0.0f; }, "sensor", "gain"},
        {"sensor noise < 0", [](EmulationProfile& p) { p.stage.sensor.noise_rms = -0.1f; }, "sensor", "noise_rms"},
        {"plant kind", [](EmulationProfile& p) { p.stage.plant.hysteresis = static_cast<HysteresisKind>(9); }, "plant", "hysteresis"},
        {"plant sections 7", [](EmulationProfile& p) { p.stage.plant.sections = 7; }, "plant", "sections"},
        {"plant pi count 17", [](EmulationProfile& p) { p.stage.plant.pi.count = 17; }, "plant", "count"},
        {"plant pi thresholds", [](EmulationProfile& p) { p.stage.plant.pi.thresholds[1] = -1.0f; }, "plant", "thresholds"},
        {"plant dahl", [](EmulationProfile& p) { p.stage.plant.hysteresis = HysteresisKind::kDahl; p.stage.plant.dahl.alpha2 = 0.0f; }, "plant", nullptr},
        {"plant linear gain", [](EmulationProfile& p) { p.stage.plant.hysteresis = HysteresisKind::kNone; p.stage.plant.linear_gain_um_per_V = s_nan; }, "plant", "linear_gain_um_per_V"},
        {"sensor offset NaN", [](EmulationProfile& p) { p.stage.sensor.offset_um = s_nan; }, "sensor", "offset_um"},
        {"sensor gain error", [](EmulationProfile& p) { p.stage.sensor.gain_error = 0.75f; }, "sensor", "gain_error"},
        {"mains count 255", [](EmulationProfile& p) { p.stage.sensor.mains.count = 300; }, "sensor", "mains.count"},
        {"mains amplitude < 0", [](EmulationProfile& p) { p.stage.sensor.mains.amplitudes_um[2] = -1.0f; }, "sensor", "mains.amplitudes_um"},
        {"mains above Nyquist", [](EmulationProfile& p) { p.stage.sensor.mains.frequency_Hz = 9000.0f; }, "sensor", "mains.frequency_Hz"},
        {"creep to_s", [](EmulationProfile& p) { p.stage.plant.creep.to_s = 30.0f; }, "plant", "creep.to_s"},
        {"creep NaN", [](EmulationProfile& p) { p.stage.plant.creep.percent_per_decade = s_nan; }, "plant", "creep.percent_per_decade"},
        {"drift inf", [](EmulationProfile& p) { p.stage.plant.drift_um_per_s = std::numeric_limits<float>::infinity(); }, "plant", "drift_um_per_s"},
        {"output map count 9", [](EmulationProfile& p) { p.stage.plant.output_map.count = 9; }, "plant", "output_map.count"},
        {"output map thresholds not ascending", [](EmulationProfile& p) { p.stage.plant.output_map.thresholds_um[1] = 5.0f; }, "plant", "output_map.thresholds_um"},
        {"output map decreasing", [](EmulationProfile& p) { p.stage.plant.output_map.weights[1] = -0.95f; }, "plant", "output_map.weights"},
    };
    for (const Case& c : cases) {
        SCOPED_TRACE(c.name);
        EmulationProfile bad = sample_profile();
        c.edit(bad);
        const auto blob = encode(bad);  // encoding does not validate
        EmulationProfile out;
        out.loop_rate_Hz = 777;  // sentinel
        const Status s = decode_profile(blob, out);
        ASSERT_FALSE(s.ok());
        if (c.group != nullptr) {
            ASSERT_NE(s.group, nullptr);
            EXPECT_STREQ(s.group, c.group);
        } else {
            EXPECT_EQ(s.group, nullptr);
        }
        if (c.field != nullptr) {
            EXPECT_STREQ(s.field, c.field);
        }
        EXPECT_NE(s.message, nullptr);
        EXPECT_EQ(out.loop_rate_Hz, 777u);
        EXPECT_TRUE(same(out, [] { EmulationProfile e; e.loop_rate_Hz = 777; return e; }()));
    }
}

TEST(EmulationProfile, EveryFramingRejectionNamesTheHeaderField) {
    const auto good = encode(sample_profile());
    auto expect = [](std::vector<uint8_t> b, const char* field) {
        EmulationProfile out;
        out.voltage_full_scale_V = 3.5f;
        const Status s = decode_profile(b, out);
        ASSERT_FALSE(s.ok());
        EXPECT_STREQ(s.field, field);
        EXPECT_EQ(out.voltage_full_scale_V, 3.5f);
    };
    expect({}, "length");
    expect(std::vector<uint8_t>(good.begin(), good.begin() + 15), "length");
    {
        auto b = good;
        b[0] ^= 1;  // magic
        expect(b, "magic");
        EXPECT_FALSE(profile_present(b));
    }
    {
        auto b = good;
        b[4] = 1;  // version 1: the layout before the real-stage effects
        expect(b, "version");
        EXPECT_TRUE(profile_present(b));
        b[4] = 2;  // version 2: the layout before the output map
        expect(b, "version");
    }
    {
        auto b = good;
        b[7] = 1;  // reserved
        expect(b, "reserved");
    }
    {
        auto b = good;
        put32(b, 8, kEmulationProfileBodyBytes + 4);  // length not the v3 layout
        expect(b, "length");
    }
    // Body cut short of the declared length.
    expect(std::vector<uint8_t>(good.begin(), good.end() - 1), "length");
    for (std::size_t at : {std::size_t{16}, std::size_t{100}, good.size() - 1}) {
        auto b = good;
        b[at] ^= 0x10;  // one flipped bit anywhere in the body
        expect(b, "crc");
        reseal(b);  // with a matching CRC it decodes (validly or not) -- the CRC was the reason
        EmulationProfile out;
        const Status s = decode_profile(b, out);
        EXPECT_TRUE(s.ok() || std::strcmp(s.field, "crc") != 0);
    }
    {
        auto b = good;
        b[12] ^= 0x01;  // the CRC field itself
        expect(b, "crc");
    }
}

// The emulated boards now run the reference plant inside a StageModel of
// ideal parts (the profile-less default). Ideal converters, a unit amplifier
// and sensor without bandwidth or noise pass values unchanged, so the stage
// must equal the bare HammersteinPlant bit for bit (exact comparison: the
// same float operations in the same order, nothing else).
TEST(EmulationProfile, IdealStageIsTheBarePlant) {
    EmulationProfile p;
    p.stage.plant = reference::plant();
    ASSERT_TRUE(validate(p).ok());
    StageModel stage;
    ASSERT_TRUE(stage.configure(p.stage).ok());
    HammersteinPlant plant;
    ASSERT_TRUE(plant.configure(reference::plant()).ok());
    // A 10 Hz triangle of +-9 V with a small seeded wobble, 20 000 samples.
    uint32_t s = 12345;
    for (int k = 0; k < 20000; ++k) {
        s = s * 1664525u + 1013904223u;
        const float tri = static_cast<float>(k % 10000 < 5000 ? k % 10000 : 10000 - k % 10000) / 5000.0f;
        const float u = 18.0f * tri - 9.0f + static_cast<float>(s >> 8) * (0.01f / 16777216.0f);
        ASSERT_EQ(std::bit_cast<uint32_t>(stage.step(u)), std::bit_cast<uint32_t>(plant.step(u))) << "sample " << k;
    }
}

// ---- the axes blob (axes/emulation_axes_profile.hpp) ----------------------

namespace {

// Three axes: axis 0 the sample profile's stage, axes 1 and 2 variants of
// it, and four coupling paths of one and two sections.
EmulationAxesProfile sample_axes(const EmulationProfile& first) {
    EmulationAxesProfile a;
    a.axes = 3;
    a.stage.axes = 3;
    for (int i = 1; i < 3; ++i) {
        const std::size_t k = static_cast<std::size_t>(i);
        a.position_full_scale_um[k] = 40.0f * static_cast<float>(i);
        a.voltage_full_scale_V[k] = 100.0f + static_cast<float>(i);
        a.stage.axis[k] = first.stage;
        a.stage.axis[k].sensor.seed = 777u + k;
        a.stage.axis[k].plant.linear_gain_um_per_V = 0.5f + 0.125f * static_cast<float>(i);
    }
    a.stage.paths = 4;
    const int from[4] = {0, 1, 0, 1}, to[4] = {1, 0, 2, 2};
    for (int k = 0; k < 4; ++k) {
        CouplingPath& p = a.stage.coupling[static_cast<std::size_t>(k)];
        p.from = from[k];
        p.to = to[k];
        p.sections = k % 2 + 1;
        p.filter[0] = SosSection{0.01 * (k + 1), 0.002, 0.0, -0.5, 0.06};
        p.filter[1] = SosSection{1.0, -0.25, 0.0, 0.125, 0.0};
    }
    return a;
}

std::vector<uint8_t> encode_axes(const EmulationAxesProfile& a) {
    std::vector<uint8_t> b(kEmulationAxesProfileMaxBytes, 0xA5);
    const std::size_t n = encode_axes_profile(a, b);
    EXPECT_EQ(n, kBlobHeaderBytes + kEmulationAxesBodyBytes);
    b.resize(n);
    return b;
}

}  // namespace

TEST(EmulationAxesProfile, RoundTripIsExactAndAxisZeroIsTheProfiles) {
    const EmulationProfile first = sample_profile();
    ASSERT_TRUE(validate(first).ok());
    const EmulationAxesProfile a = sample_axes(first);
    const std::vector<uint8_t> b = encode_axes(a);
    EmulationAxesProfile out;
    CoupledStage scratch;
    const Status s = decode_axes_profile(b, first, out, scratch);
    ASSERT_TRUE(s.ok()) << (s.group ? s.group : "") << "." << s.field << ": " << s.message;
    EXPECT_EQ(out.axes, 3);
    EXPECT_EQ(out.stage.axes, 3);
    EXPECT_EQ(out.position_full_scale_um[0], first.position_full_scale_um);
    EXPECT_EQ(out.voltage_full_scale_V[0], first.voltage_full_scale_V);
    EmulationProfile axis0 = first, again = first;
    axis0.stage = out.stage.axis[0];
    EXPECT_TRUE(same(axis0, first));
    // Every travelling value comes back: encoded again, the same bytes.
    EXPECT_EQ(encode_axes(out), b);
    for (int i = 1; i < 3; ++i) {
        again.stage = out.stage.axis[static_cast<std::size_t>(i)];
        EmulationProfile want = first;
        want.stage = a.stage.axis[static_cast<std::size_t>(i)];
        EXPECT_TRUE(same(again, want)) << "axis " << i;
    }
    // The layout: axes, then axis 1's full scales at the body's start + 1.
    EXPECT_EQ(le32(b, 0), kEmulationAxesMagic);
    EXPECT_EQ(b[16], 3u);
    EXPECT_EQ(le32(b, 17), std::bit_cast<uint32_t>(40.0f));
    EXPECT_EQ(le32(b, 21), std::bit_cast<uint32_t>(101.0f));
    // The paths' count after the two axis blocks.
    EXPECT_EQ(b[16 + 1 + 2 * (8 + kEmulationStageBytes)], 4u);
}

TEST(EmulationAxesProfile, RejectionsNameTheFieldAndLeaveOutUntouched) {
    const EmulationProfile first = sample_profile();
    const EmulationAxesProfile good = sample_axes(first);
    struct AxesCase {
        const char* name;
        void (*edit)(EmulationAxesProfile&);
        const char* group;
        const char* field;
    };
    const AxesCase cases[] = {
        {"one axis", [](EmulationAxesProfile& a) { a.axes = 1; }, nullptr, "axes"},
        {"four axes", [](EmulationAxesProfile& a) { a.axes = 4; }, nullptr, "axes"},
        {"full scale", [](EmulationAxesProfile& a) { a.position_full_scale_um[2] = 0.0f; }, "axis[2]",
         "position_full_scale_um"},
        {"voltage scale", [](EmulationAxesProfile& a) { a.voltage_full_scale_V[1] = -1.0f; }, "axis[1]",
         "voltage_full_scale_V"},
        {"another rate", [](EmulationAxesProfile& a) { a.stage.axis[1].rate_Hz = 40000.0f; }, "axis[1]", "rate_Hz"},
        {"a path to itself", [](EmulationAxesProfile& a) { a.stage.coupling[1].to = 1; }, "coupling[1]", "to"},
        {"a path to no axis", [](EmulationAxesProfile& a) { a.stage.coupling[2].to = 3; }, "coupling[2]", "to"},
        {"seven paths", [](EmulationAxesProfile& a) { a.stage.paths = 7; }, nullptr, "paths"},
    };
    for (const AxesCase& c : cases) {
        EmulationAxesProfile bad = good;
        c.edit(bad);
        const std::vector<uint8_t> b = encode_axes(bad);
        EmulationAxesProfile out;
        out.axes = 99;
        CoupledStage scratch;
        const Status s = decode_axes_profile(b, first, out, scratch);
        ASSERT_FALSE(s.ok()) << c.name;
        EXPECT_STREQ(s.field, c.field) << c.name;
        if (c.group == nullptr) {
            EXPECT_EQ(s.group, nullptr) << c.name;
        } else {
            ASSERT_NE(s.group, nullptr) << c.name;
            EXPECT_STREQ(s.group, c.group) << c.name;
        }
        EXPECT_EQ(out.axes, 99) << c.name << ": out written";
    }
    // Framing: another blob's magic, a flipped body byte (CRC).
    std::vector<uint8_t> b = encode_axes(good);
    EmulationAxesProfile out;
    CoupledStage scratch;
    EXPECT_STREQ(decode_axes_profile(encode(first), first, out, scratch).field, "magic");
    b[40] ^= 0x10;
    EXPECT_STREQ(decode_axes_profile(b, first, out, scratch).field, "crc");
    // Below the board cases and the profile, inside what memory.ld leaves out.
    EXPECT_LE(kEmulationAxesProfileAddress + kEmulationAxesProfileMaxBytes, 0x003FE000u);
    EXPECT_GE(kEmulationAxesProfileAddress, 0x00400000u - 16u * 1024u);
}
