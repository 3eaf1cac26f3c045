// The scan feed: the approach from a given start has no jump (every step
// within the approach's bound per tick), the scan's first point is reached
// exactly when its clock starts, the sync words are the generator's alone
// shifted by the approach's ticks, float and Q31; refusals change nothing;
// feed() writes the pipeline's setpoints.
#include <gtest/gtest.h>

#include <cmath>
#include <cstdint>
#include <string>
#include <vector>

#include <array>
#include "piezoloop/scan/scan_feed.hpp"

using piezoloop::Q31;
using piezoloop::ScanConfig;
using piezoloop::ScanFeed;
using piezoloop::ScanGenerator;
using piezoloop::ScanPattern;
using piezoloop::ScanPoint;
using piezoloop::SignalScale;

namespace {

constexpr float kRate_Hz = 100000.0f;
const SignalScale kScale{50.0f};

ScanConfig raster() {
    ScanConfig c;
    c.pattern = ScanPattern::kRaster;
    c.sample_rate_Hz = kRate_Hz;
    c.centre_x_um = 5.0f;
    c.centre_y_um = -3.0f;
    c.size_x_um = 10.0f;
    c.size_y_um = 8.0f;
    c.pixels_per_line = 16;
    c.lines_per_frame = 4;
    c.line_rate_Hz = 200.0f;
    c.turnaround_s = 0.0005f;
    c.hold_z_um = 2.0f;
    return c;
}

ScanConfig spiral() {
    ScanConfig c;
    c.pattern = ScanPattern::kSpiral;
    c.sample_rate_Hz = kRate_Hz;
    c.radius_um = 6.0f;
    c.turns = 4;
    c.turn_rate_Hz = 200.0f;
    c.pixels_per_line = 32;
    return c;
}

double as_um(float v) { return v; }
double as_um(Q31 v) { return static_cast<double>(v.raw()) * 0x1p-31 * kScale.full_scale; }

// Runs a feed from `from` and checks the three properties against the
// generator alone.
template <class T>
void check_feed(const ScanConfig& c, float from_x_um, float from_y_um, float from_z_um) {
    ScanFeed<T> feed(kScale, kScale, kScale, kRate_Hz);
    const T fx = kScale.to_sample<T>(from_x_um), fy = kScale.to_sample<T>(from_y_um),
            fz = kScale.to_sample<T>(from_z_um);
    ASSERT_TRUE(feed.start(c, fx, fy, fz).ok());
    ScanGenerator<T> alone(kScale, kScale, kScale);
    ASSERT_TRUE(alone.configure(c).ok());
    const ScanPoint<T> first = alone.start_point();

    const uint32_t a = feed.approach_ticks();
    ASSERT_GT(a, 10u) << "the start is far from the scan's first point";
    // The approach's bound per tick, in µm: its peak velocity, 15/8 of its
    // unit (approach.hpp); float: 1e-5 relative for the rounding of the
    // samples (2 float ulp of coordinates below 32 um, both samples
    // rounded), Q31: 2 LSB (each sample's convex combination is rounded).
    double bound_um;
    if constexpr (std::is_same_v<T, float>) bound_um = 15.0 / 8.0 * feed.approach_unit(0) + 2.0 * 32.0 * 0x1p-24;
    else bound_um = (15.0 / 8.0 * feed.approach_unit(0) + 2.0) * 0x1p-31 * kScale.full_scale;

    ScanPoint<T> prev{fx, fy, fz, 0};
    for (uint32_t k = 0; k < a; ++k) {
        EXPECT_TRUE(feed.approaching());
        const ScanPoint<T> p = feed.step();
        EXPECT_EQ(p.sync, 0u) << k;
        EXPECT_LE(std::fabs(as_um(p.x) - as_um(prev.x)), bound_um) << "x, tick " << k;
        EXPECT_LE(std::fabs(as_um(p.y) - as_um(prev.y)), bound_um) << "y, tick " << k;
        EXPECT_LE(std::fabs(as_um(p.z) - as_um(prev.z)), bound_um) << "z, tick " << k;
        prev = p;
    }
    // The last approach sample is within a step of the first point.
    EXPECT_LE(std::fabs(as_um(first.x) - as_um(prev.x)), bound_um);
    EXPECT_LE(std::fabs(as_um(first.y) - as_um(prev.y)), bound_um);
    EXPECT_LE(std::fabs(as_um(first.z) - as_um(prev.z)), bound_um);
    EXPECT_FALSE(feed.approaching());

    // From here on: the generator alone, bit for bit, until it is done.
    uint64_t ticks = 0, events = 0;
    ScanPoint<T> g;
    while (!alone.done()) {
        ASSERT_TRUE(feed.running());
        g = alone.step();
        const ScanPoint<T> p = feed.step();
        ASSERT_EQ(p.x, g.x) << ticks;
        ASSERT_EQ(p.y, g.y) << ticks;
        ASSERT_EQ(p.z, g.z) << ticks;
        ASSERT_EQ(p.sync, g.sync) << "tick " << a + ticks;
        events += p.sync != 0;
        ++ticks;
    }
    EXPECT_GT(events, 0u);
    EXPECT_TRUE(feed.done());
    EXPECT_EQ(feed.ticks(), a + ticks);
    // Done: the setpoints hold the last point, no more events.
    const ScanPoint<T> held = feed.step();
    EXPECT_EQ(held.x, g.x);
    EXPECT_EQ(held.y, g.y);
    EXPECT_EQ(held.sync, 0u);
}

}  // namespace

TEST(ScanFeed, RasterFromAFarStartFloat) { check_feed<float>(raster(), -20.0f, 15.0f, 0.0f); }
TEST(ScanFeed, RasterFromAFarStartQ31) { check_feed<Q31>(raster(), -20.0f, 15.0f, 0.0f); }
TEST(ScanFeed, SpiralFromAFarStartFloat) { check_feed<float>(spiral(), 12.0f, -9.0f, 3.0f); }
TEST(ScanFeed, SpiralFromAFarStartQ31) { check_feed<Q31>(spiral(), 12.0f, -9.0f, 3.0f); }

TEST(ScanFeed, StartAtTheFirstPointHasNoApproach) {
    ScanGenerator<float> g(kScale, kScale, kScale);
    ASSERT_TRUE(g.configure(spiral()).ok());
    const ScanPoint<float> first = g.start_point();
    ScanFeed<float> feed(kScale, kScale, kScale, kRate_Hz);
    ASSERT_TRUE(feed.start(spiral(), first.x, first.y, first.z).ok());
    EXPECT_EQ(feed.approach_ticks(), 0u);
    const ScanPoint<float> p = feed.step();
    EXPECT_EQ(p.x, first.x);
    EXPECT_EQ(p.y, first.y);
    EXPECT_EQ(p.sync, first.sync);
}

TEST(ScanFeed, RefusalsNameTheFieldAndChangeNothing) {
    ScanFeed<float> feed(kScale, kScale, kScale, kRate_Hz);
    ASSERT_TRUE(feed.start(raster(), 0.0f, 0.0f).ok());
    for (int k = 0; k < 100; ++k) feed.step();
    const uint64_t ticks = feed.ticks();

    ScanConfig wrong_rate = raster();
    wrong_rate.sample_rate_Hz = 50000.0f;
    piezoloop::Status s = feed.start(wrong_rate, 0.0f, 0.0f);
    ASSERT_FALSE(s.ok());
    EXPECT_EQ(std::string(s.field), "sample_rate_Hz");
    EXPECT_EQ(std::string(s.group), "scan");

    ScanConfig too_many = raster();
    too_many.pixels_per_line = 100000;
    s = feed.start(too_many, 0.0f, 0.0f);
    ASSERT_FALSE(s.ok());
    EXPECT_EQ(std::string(s.field), "pixels_per_line");

    s = feed.start(raster(), NAN, 0.0f);
    ASSERT_FALSE(s.ok());
    EXPECT_EQ(std::string(s.field), "from");

    EXPECT_TRUE(feed.running());
    EXPECT_EQ(feed.ticks(), ticks);
    EXPECT_EQ(feed.generator().config().pixels_per_line, 16u);
}

// A stand-in with a MultiAxisPipeline's interface for setpoints.
template <int N>
struct SetpointSink {
    using Samples = std::array<float, N>;
    struct Axis {
        float r = -1.0f;
        bool set_setpoint(float v) { r = v; return true; }
    };
    std::array<Axis, N> axes{};
    Axis& axis(int i) { return axes[static_cast<std::size_t>(i)]; }
};

TEST(ScanFeed, FeedWritesEachAxisSetpoint) {
    ScanFeed<float> feed(kScale, kScale, kScale, kRate_Hz);
    ASSERT_TRUE(feed.start(raster(), 0.0f, 0.0f, 0.0f).ok());
    SetpointSink<3> three;
    SetpointSink<2> two;
    for (int k = 0; k < 50; ++k) {
        const ScanPoint<float> p = feed.feed(three);
        EXPECT_EQ(three.axis(0).r, p.x);
        EXPECT_EQ(three.axis(1).r, p.y);
        EXPECT_EQ(three.axis(2).r, p.z);
        const ScanPoint<float> q = feed.feed(two);
        EXPECT_EQ(two.axis(0).r, q.x);
        EXPECT_EQ(two.axis(1).r, q.y);
    }
    EXPECT_NE(three.axis(2).r, -1.0f);
}

TEST(ScanFeed, StopHoldsTheSetpoints) {
    ScanFeed<float> feed(kScale, kScale, kScale, kRate_Hz);
    ASSERT_TRUE(feed.start(spiral(), 1.0f, 1.0f).ok());
    ScanPoint<float> p;
    for (int k = 0; k < 500; ++k) p = feed.step();
    feed.stop();
    EXPECT_TRUE(feed.done());
    const ScanPoint<float> q = feed.step();
    EXPECT_EQ(q.x, p.x);
    EXPECT_EQ(q.y, p.y);
    EXPECT_EQ(q.sync, 0u);
}
