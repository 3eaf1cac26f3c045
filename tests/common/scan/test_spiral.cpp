// The spiral (through the generator, float) against its closed forms: CAV
// angular rate constant and r linear in time, CLV tangential speed constant
// outside the centre region, the outer radius reached, the return to the
// centre without a jump, and the events (a line per turn, P pixels a turn).
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstdint>

#include "piezoloop/scan/scan_generator.hpp"
#include "scan_fixture.hpp"

using piezoloop::ScanConfig;
using piezoloop::ScanGenerator;
using piezoloop::ScanPattern;
using piezoloop::SpiralMode;
using piezoloop::test::float_ulp;
using piezoloop::test::run_scan;
using piezoloop::test::ScanRun;

namespace {

ScanConfig spiral(SpiralMode mode) {
    ScanConfig c;
    c.pattern = ScanPattern::kSpiral;
    c.spiral_mode = mode;
    c.radius_um = 5.0f;
    c.turns = 8;
    c.turn_rate_Hz = 400.0f;  // 250 ticks a turn
    c.linear_speed_um_s = 2000.0f;
    c.pixels_per_line = 16;
    c.frames = 1;
    return c;
}

// A position's error: the sine table (2.95e-7 of the radius), a few LSB of
// the reach, 2 float ulp of the radius.
double position_tol(const ScanGenerator<float>& g) {
    return g.reach_um() * (2.95e-7 + 4.0 * 0x1p-31) + 2.0 * float_ulp(g.reach_um());
}

}  // namespace

TEST(Spiral, ConstantAngularVelocityClosedForm) {
    const ScanConfig c = spiral(SpiralMode::kConstantAngularVelocity);
    ScanGenerator<float> g;
    ASSERT_TRUE(g.configure(c).ok());
    const ScanRun r = run_scan(g);
    const double N = 250.0, K = c.turns, R = c.radius_um, tol = position_tol(g);
    const std::size_t out = static_cast<std::size_t>(N * K);
    EXPECT_EQ(g.line_period_ticks(), 250u);
    ASSERT_EQ(r.size(), 2 * out);
    EXPECT_EQ(g.repetitive_period_ticks(), 2 * out);
    for (std::size_t n = 0; n < out; ++n) {
        const double rad = R * static_cast<double>(n) / (N * K), a = 2.0 * M_PI * static_cast<double>(n) / N;
        ASSERT_NEAR(r.x[n], rad * std::cos(a), tol) << n;
        ASSERT_NEAR(r.y[n], rad * std::sin(a), tol) << n;
    }
    // The angle advances 2 pi / N every tick (measured where r > R / 10,
    // where the position's error is below tol / r rad).
    double worst = 0.0;
    for (std::size_t n = out / 10; n + 1 < out; ++n) {
        const double d = std::remainder(std::atan2(r.y[n + 1], r.x[n + 1]) - std::atan2(r.y[n], r.x[n]), 2.0 * M_PI);
        worst = std::max(worst, std::fabs(d - 2.0 * M_PI / N));
    }
    EXPECT_LE(worst, 2.0 * tol / (0.1 * R));
    // The return: the mirror image, back to the centre.
    for (std::size_t m = 1; m < out; m += 7) {
        EXPECT_NEAR(r.x[out + m], r.x[out - m], tol);
        EXPECT_NEAR(r.y[out + m], -r.y[out - m], tol);
    }
    EXPECT_NEAR(r.x[out], R, tol);  // the outer radius reached
    EXPECT_NEAR(r.y[out], 0.0, tol);
    const auto hold = g.step();
    EXPECT_NEAR(hold.x, 0.0, tol);
    EXPECT_NEAR(hold.y, 0.0, tol);
}

TEST(Spiral, ConstantLinearVelocityOutsideTheCentreRegion) {
    const ScanConfig c = spiral(SpiralMode::kConstantLinearVelocity);
    ScanGenerator<float> g;
    ASSERT_TRUE(g.configure(c).ok());
    const ScanRun r = run_scan(g);
    const auto& p = g.spiral_params();
    const double fs = c.sample_rate_Hz, v = g.clv_speed_um_s() / fs;  // µm per tick
    EXPECT_NEAR(g.clv_speed_um_s(), c.linear_speed_um_s, 0.01 * c.linear_speed_um_s);  // n_c rounded to a tick
    ASSERT_EQ(r.size(), 2 * std::size_t{p.out_ticks});
    // Centre region: the turn rate (2 pi / N a tick).
    for (std::size_t n = p.centre_ticks / 2; n + 1 < p.centre_ticks; ++n) {
        const double d = std::remainder(std::atan2(r.y[n + 1], r.x[n + 1]) - std::atan2(r.y[n], r.x[n]), 2.0 * M_PI);
        EXPECT_NEAR(d, 2.0 * M_PI / p.turn_ticks, 1e-3 * 2.0 * M_PI / p.turn_ticks) << n;
    }
    // Outside it the speed is v sqrt(1 + 1/theta^2) (the radial part of an
    // Archimedean spiral): within 1/(2 theta^2) of v, plus the root's slope
    // error (linear interpolation of sqrt over 2^-10 wide segments: below
    // 0.1 %) and the positions' noise. Stated: within 0.5 % past 2 turns.
    double worst = 0.0;
    for (std::size_t n = p.centre_ticks; n + 1 < p.out_ticks; ++n) {
        const double rad = std::hypot(r.x[n], r.y[n]);
        const double theta = 2.0 * M_PI * c.turns * rad / c.radius_um;
        const double speed = std::hypot(r.x[n + 1] - r.x[n], r.y[n + 1] - r.y[n]);
        const double bound = 1.0 / (2.0 * theta * theta) + 1e-3 + 4.0 * position_tol(g) / v;
        ASSERT_LE(std::fabs(speed / v - 1.0), bound) << n;
        if (theta >= 4.0 * M_PI) worst = std::max(worst, std::fabs(speed / v - 1.0));
    }
    EXPECT_LE(worst, 0.005);
    RecordProperty("clv_speed_error_past_2_turns", std::to_string(worst));
    // The outer radius reached at N_out, the centre at the frame's end.
    EXPECT_NEAR(r.x[p.out_ticks], c.radius_um, position_tol(g));
    EXPECT_NEAR(r.y[p.out_ticks], 0.0, position_tol(g));
    double r_max = 0.0;
    for (std::size_t n = 0; n < r.size(); ++n) r_max = std::max(r_max, std::hypot(r.x[n], r.y[n]));
    EXPECT_NEAR(r_max, c.radius_um, position_tol(g));
    // No jump: no step beyond the speed (plus the radial part near the centre).
    for (std::size_t n = 0; n + 1 < r.size(); ++n) {
        ASSERT_LE(std::hypot(r.x[n + 1] - r.x[n], r.y[n + 1] - r.y[n]), 1.05 * v) << n;
    }
}

TEST(Spiral, LinePerTurnAndPixelsPerLine) {
    for (const SpiralMode mode : {SpiralMode::kConstantAngularVelocity, SpiralMode::kConstantLinearVelocity}) {
        ScanConfig c = spiral(mode);
        c.frames = 2;
        ScanGenerator<float> g;
        ASSERT_TRUE(g.configure(c).ok());
        const ScanRun r = run_scan(g);
        const auto frames = r.ticks_with(piezoloop::kSyncFrameStart);
        const auto lines = r.ticks_with(piezoloop::kSyncLineStart);
        const auto pixels = r.ticks_with(piezoloop::kSyncPixel);
        ASSERT_EQ(frames.size(), 2u);
        EXPECT_EQ(frames[1], g.frame_period_ticks());
        ASSERT_EQ(lines.size(), 2u * c.turns);
        EXPECT_EQ(g.lines_per_frame(), c.turns);
        EXPECT_EQ(pixels.size(), 2u * c.turns * c.pixels_per_line);
        // Each line starts with its first pixel and holds P; the pixel's
        // angle is within a tick's turn past j / P of a turn.
        const std::size_t out = g.spiral_params().out_ticks;
        for (std::size_t l = 0; l < lines.size(); ++l) {
            const std::size_t frame_start = frames[l / c.turns];
            const std::size_t end = (l + 1) % c.turns != 0 ? lines[l + 1] : frame_start + out;
            const auto in_line = std::count_if(pixels.begin(), pixels.end(),
                                               [&](std::size_t t) { return t >= lines[l] && t < end; });
            EXPECT_EQ(in_line, c.pixels_per_line) << "mode " << static_cast<int>(mode) << " line " << l;
            EXPECT_TRUE(r.sync[lines[l]] & piezoloop::kSyncPixel);
        }
        for (const std::size_t t : pixels) {
            double a = std::atan2(r.y[t], r.x[t]) / (2.0 * M_PI);
            if (t % g.frame_period_ticks() == 0) continue;  // the centre: no angle
            a -= std::floor(a);
            const double j = a * c.pixels_per_line;
            const double past = (j - std::floor(j + 1e-6)) / c.pixels_per_line;  // turns past j / P
            EXPECT_LE(past, 1.0 / g.spiral_params().turn_ticks + 1e-4) << t;
        }
    }
}
