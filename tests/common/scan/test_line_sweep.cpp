// The raster's and the cycloid's line sweep (through the generator, float):
// constant velocity over the used part, turnaround jerk within its stated
// bound, exact line and frame timing, staircase steps inside the
// turnaround, the retrace speed, no jumps anywhere, the cycloid's closed form.
// Finite differences of float positions: their noise is a few float ulp of
// the largest coordinate plus a few Q31 LSB of the reach (the integer path's
// roundings), named kNoise below.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <vector>

#include "piezoloop/scan/scan_generator.hpp"
#include "scan_fixture.hpp"

using piezoloop::ScanConfig;
using piezoloop::ScanGenerator;
using piezoloop::ScanPattern;
using piezoloop::SlowAxis;
using piezoloop::test::float_ulp;
using piezoloop::test::run_scan;
using piezoloop::test::ScanRun;

namespace {

ScanConfig raster() {
    ScanConfig c;
    c.pattern = ScanPattern::kRaster;
    c.size_x_um = 10.0f;
    c.size_y_um = 8.0f;
    c.line_rate_Hz = 200.0f;
    c.retrace_speed_factor = 2.0f;
    c.overscan_fraction = 0.1f;
    c.turnaround_s = 0.0005f;  // 50 ticks
    c.pixels_per_line = 16;
    c.lines_per_frame = 6;
    c.frames = 2;
    return c;
}

// One position's noise: 2 float ulp of the largest coordinate, 4 LSB of the reach.
double noise(const ScanGenerator<float>& g, const ScanRun& r) {
    double m = 0.0;
    for (std::size_t i = 0; i < r.size(); ++i) m = std::max({m, std::fabs(r.x[i]), std::fabs(r.y[i])});
    return 2.0 * float_ulp(m) + 4.0 * g.reach_um() * 0x1p-31;
}

struct Sweep {
    ScanGenerator<float> g;
    ScanRun run;
    double v_trace = 0.0, v_retrace = 0.0;  // µm per tick
    uint32_t lead = 0, line = 0, frame = 0;
    explicit Sweep(const ScanConfig& c) {
        const auto s = g.configure(c);
        EXPECT_TRUE(s.ok()) << s.field << ": " << s.message;
        run = run_scan(g);
        const auto& p = g.sweep_params();
        v_trace = c.size_x_um / static_cast<double>(p.used_ticks);
        v_retrace = p.bidirectional ? v_trace
                                    : v_trace * (p.cv_ticks + p.turn_ticks) / (p.retrace_ticks + p.turn_ticks);
        lead = g.lead_in_ticks();
        line = g.line_period_ticks();
        frame = g.frame_period_ticks();
    }
};

}  // namespace

TEST(LineSweep, LineAndFrameTimingExactInTicks) {
    const ScanConfig c = raster();
    Sweep s(c);
    const auto& p = s.g.sweep_params();
    EXPECT_EQ(s.line, p.cv_ticks + p.retrace_ticks + 2 * p.turn_ticks);
    EXPECT_EQ(s.frame, s.line * c.lines_per_frame);
    EXPECT_EQ(p.used_ticks % c.pixels_per_line, 0u);  // whole ticks a pixel
    // The run: lead-in, the frames, done (the lead-out is the last turnaround).
    EXPECT_EQ(s.run.size(), std::size_t{s.lead} + c.frames * s.frame);
    const auto lines = s.run.ticks_with(piezoloop::kSyncLineStart);
    ASSERT_EQ(lines.size(), std::size_t{c.frames} * c.lines_per_frame);
    for (std::size_t i = 0; i < lines.size(); ++i) EXPECT_EQ(lines[i], s.lead + i * s.line);
    const auto frames = s.run.ticks_with(piezoloop::kSyncFrameStart);
    ASSERT_EQ(frames.size(), std::size_t{c.frames});
    for (std::size_t f = 0; f < frames.size(); ++f) EXPECT_EQ(frames[f], s.lead + f * s.frame);
    // P pixel clocks a line, every used / P ticks after the overscan.
    const auto pixels = s.run.ticks_with(piezoloop::kSyncPixel);
    ASSERT_EQ(pixels.size(), lines.size() * c.pixels_per_line);
    const uint32_t per_pixel = p.used_ticks / c.pixels_per_line;
    for (std::size_t i = 0; i < pixels.size(); ++i) {
        const std::size_t l = i / c.pixels_per_line, j = i % c.pixels_per_line;
        EXPECT_EQ(pixels[i], lines[l] + p.overscan_ticks + j * per_pixel) << i;
    }
    EXPECT_TRUE(s.g.done());
}

TEST(LineSweep, UsedPartAtConstantVelocityAndPixelsEvenInPosition) {
    const ScanConfig c = raster();
    Sweep s(c);
    const double tol = 2.0 * noise(s.g, s.run);
    const auto& p = s.g.sweep_params();
    const auto lines = s.run.ticks_with(piezoloop::kSyncLineStart);
    double worst = 0.0;
    for (const std::size_t l : lines) {
        // The whole constant-velocity run, overscan included.
        for (std::size_t n = l; n + 1 < l + p.cv_ticks; ++n) {
            worst = std::max(worst, std::fabs(s.run.x[n + 1] - s.run.x[n] - s.v_trace));
        }
        // Pixels: size_x / P apart, the used width exactly size_x.
        const std::size_t first = l + p.overscan_ticks;
        const std::size_t per_pixel = p.used_ticks / c.pixels_per_line;
        for (uint32_t j = 1; j < c.pixels_per_line; ++j) {
            EXPECT_NEAR(s.run.x[first + j * per_pixel] - s.run.x[first + (j - 1) * per_pixel],
                        c.size_x_um / c.pixels_per_line, tol);
        }
        EXPECT_NEAR(s.run.x[first], -0.5 * c.size_x_um, tol);
        EXPECT_NEAR(s.run.x[first + p.used_ticks], 0.5 * c.size_x_um, tol);
    }
    EXPECT_LE(worst, tol);
    // The retrace: faster by about the factor (whole ticks), closing the line.
    const std::size_t mid = lines[0] + p.cv_ticks + p.turn_ticks + p.retrace_ticks / 2;
    EXPECT_NEAR(s.run.x[mid + 1] - s.run.x[mid], -s.v_retrace, tol);
    // Within the retrace's rounding to a tick: 0.5 / (retrace + turnaround).
    EXPECT_NEAR(s.v_retrace / s.v_trace, c.retrace_speed_factor,
                c.retrace_speed_factor * 0.5 / (p.retrace_ticks + p.turn_ticks));
}

TEST(LineSweep, JerkWithinItsBoundEverywhere) {
    // Third differences at a stride h bound the jerk over 3h ticks:
    // |D3_h x| <= J h^3 (mean value theorem), J = 6 |v_out - v_in| / T^2 for
    // the turnarounds (the largest change: trace to retrace), 60 dy / T^3
    // for the staircase's minimum-jerk step. Plus 8 times a position's noise.
    for (const bool bidirectional : {false, true}) {
        ScanConfig c = raster();
        c.bidirectional = bidirectional;
        Sweep s(c);
        const double T = s.g.sweep_params().turn_ticks;
        const double jx = 6.0 * (s.v_trace + s.v_retrace) / (T * T);
        const double jy = 60.0 * (c.size_y_um / (c.lines_per_frame - 1)) / (T * T * T);
        const double h = 5.0, eps = 8.0 * noise(s.g, s.run);
        double peak_x = 0.0, peak_y = 0.0;
        for (std::size_t n = 0; n + 15 < s.run.size(); ++n) {
            auto d3 = [&](const std::vector<double>& v) {
                return std::fabs(v[n + 15] - 3.0 * v[n + 10] + 3.0 * v[n + 5] - v[n]);
            };
            peak_x = std::max(peak_x, d3(s.run.x));
            peak_y = std::max(peak_y, d3(s.run.y));
        }
        EXPECT_LE(peak_x, jx * h * h * h + eps) << bidirectional;
        EXPECT_LE(peak_y, jy * h * h * h + eps) << bidirectional;
        // and the bound is the turnaround's: it comes close to it.
        EXPECT_GE(peak_x, 0.5 * jx * h * h * h) << bidirectional;
        EXPECT_GE(peak_y, 0.5 * jy * h * h * h) << bidirectional;
    }
}

TEST(LineSweep, NoJumpsAnywhere) {
    for (const bool bidirectional : {false, true}) {
        for (const SlowAxis slow : {SlowAxis::kStaircase, SlowAxis::kRamp}) {
            ScanConfig c = raster();
            c.bidirectional = bidirectional;
            c.slow_axis = slow;
            Sweep s(c);
            const double tol = 2.0 * noise(s.g, s.run);
            const double v_max = std::max(s.v_trace, s.v_retrace);
            double worst = 0.0;
            for (std::size_t n = 0; n + 1 < s.run.size(); ++n) {
                worst = std::max(worst, std::fabs(s.run.x[n + 1] - s.run.x[n]));
                EXPECT_LE(std::fabs(s.run.y[n + 1] - s.run.y[n]), 2.0 * c.size_y_um / s.g.sweep_params().turn_ticks);
            }
            EXPECT_LE(worst, v_max + tol);
            // Starts at rest, ends at rest, and holds.
            // (Near rest a turnaround moves v T (S(1) - S(1 - e)) ~ 3 v e^2 T a
            // tick: below 8 v / T^2 over its last two ticks, e <= 2 / T.)
            const double T = s.g.sweep_params().turn_ticks, rest = 8.0 * v_max / (T * T) + tol;
            EXPECT_LE(std::fabs(s.run.x[1] - s.run.x[0]), rest);
            const std::size_t e = s.run.size() - 1;
            EXPECT_LE(std::fabs(s.run.x[e] - s.run.x[e - 1]), rest);
            const auto hold = s.g.step();
            EXPECT_LE(std::fabs(hold.x - s.run.x[e]), rest);
            EXPECT_EQ(hold.sync, 0u);
        }
    }
}

TEST(LineSweep, StaircaseStepsOnlyInsideTheTurnaroundBeforeEachLine) {
    for (const bool bidirectional : {false, true}) {
        ScanConfig c = raster();
        c.bidirectional = bidirectional;
        Sweep s(c);
        const uint32_t turn = s.g.sweep_params().turn_ticks;
        const double step = c.size_y_um / (c.lines_per_frame - 1);
        std::size_t moving = 0;
        for (std::size_t n = 0; n + 1 < s.run.size(); ++n) {
            if (s.run.y[n + 1] == s.run.y[n]) continue;
            ++moving;
            ASSERT_GE(n, s.lead);
            const std::size_t in_line = (n - s.lead) % s.line;
            EXPECT_GE(in_line, s.line - turn) << n;  // the line's last turnaround
        }
        EXPECT_GT(moving, 0u);
        // Each line holds its y over its sweep: -H/2 + i H / (L - 1), frames alternating.
        const auto lines = s.run.ticks_with(piezoloop::kSyncLineStart);
        for (std::size_t l = 0; l < lines.size(); ++l) {
            const std::size_t f = l / c.lines_per_frame, i = l % c.lines_per_frame;
            const double idx = f % 2 == 0 ? static_cast<double>(i) : static_cast<double>(c.lines_per_frame - 1 - i);
            EXPECT_NEAR(s.run.y[lines[l]], -0.5 * c.size_y_um + idx * step, 1e-5) << l;
        }
    }
}

TEST(LineSweep, BidirectionalRampSweepsBothWaysAndRampsTheSlowAxis) {
    ScanConfig c = raster();
    c.bidirectional = true;
    c.slow_axis = SlowAxis::kRamp;
    Sweep s(c);
    const double tol = 2.0 * noise(s.g, s.run);
    const auto lines = s.run.ticks_with(piezoloop::kSyncLineStart);
    ASSERT_EQ(lines.size(), std::size_t{c.frames} * c.lines_per_frame);
    EXPECT_EQ(s.g.repetitive_period_ticks(), 2 * s.line);
    // Every other line is the mirror image of the one before.
    for (std::size_t k = 0; k < s.line; ++k) EXPECT_NEAR(s.run.x[lines[1] + k], -s.run.x[lines[0] + k], tol);
    // The ramp: y = -H/2 + H t / T_frame up in frame 0, down in frame 1.
    for (std::size_t t = 0; t < s.frame; t += 97) {
        const double up = -0.5 * c.size_y_um + c.size_y_um * static_cast<double>(t) / s.frame;
        EXPECT_NEAR(s.run.y[s.lead + t], up, 1e-5);
        EXPECT_NEAR(s.run.y[s.lead + s.frame + t], -up, 1e-5);
    }
}

TEST(LineSweep, FramesForeverNeverEnd) {
    ScanConfig c = raster();
    c.frames = 0;
    ScanGenerator<float> g;
    ASSERT_TRUE(g.configure(c).ok());
    const std::size_t ticks = g.lead_in_ticks() + 3 * std::size_t{g.frame_period_ticks()} + 1;
    const ScanRun r = run_scan(g, ticks);
    EXPECT_FALSE(g.done());
    EXPECT_EQ(g.frames_completed(), 3u);
    EXPECT_EQ(r.ticks_with(piezoloop::kSyncFrameStart).size(), 4u);
    // Frame 2 repeats frame 0 exactly (frames alternate up and down).
    const std::size_t f0 = g.lead_in_ticks(), f2 = f0 + 2 * std::size_t{g.frame_period_ticks()};
    for (std::size_t k = 0; k < g.frame_period_ticks(); k += 13) {
        EXPECT_EQ(r.x[f0 + k], r.x[f2 + k]);
        EXPECT_EQ(r.y[f0 + k], r.y[f2 + k]);
    }
}

TEST(LineSweep, CycloidIsACircleOnTheLine) {
    // x = x_c + r cos(2 pi n / N), y = y_c + r sin(2 pi n / N) with the
    // centre (x_c, y_c) moving at v along the line's constant-velocity part.
    ScanConfig c;
    c.pattern = ScanPattern::kCycloid;
    c.size_x_um = 6.0f;
    c.size_y_um = 4.0f;
    c.radius_um = 0.5f;
    c.turn_rate_Hz = 1000.0f;  // 100 ticks a turn
    c.turns_per_line = 12;
    c.pixels_per_line = 24;
    c.lines_per_frame = 4;
    Sweep s(c);
    const double N = s.g.circle_ticks(), r = c.radius_um;
    EXPECT_EQ(N, 100.0);
    const double tol = 2.0 * noise(s.g, s.run) + r * 3e-7;
    const double v = c.size_x_um / (N * c.turns_per_line);
    const auto lines = s.run.ticks_with(piezoloop::kSyncLineStart);
    ASSERT_EQ(lines.size(), c.lines_per_frame);
    EXPECT_EQ(s.run.ticks_with(piezoloop::kSyncPixel).size(), std::size_t{c.pixels_per_line} * c.lines_per_frame);
    for (std::size_t l = 0; l < lines.size(); ++l) {
        const double dir = l % 2 == 0 ? 1.0 : -1.0;
        const double y_line = -0.5 * c.size_y_um + static_cast<double>(l) * c.size_y_um / (c.lines_per_frame - 1);
        for (std::size_t k = 0; k < N * c.turns_per_line; ++k) {
            const std::size_t n = lines[l] + k;
            const double a = 2.0 * M_PI * static_cast<double>(n) / N;
            EXPECT_NEAR(s.run.x[n], dir * (-0.5 * c.size_x_um + v * k) + r * std::cos(a), tol) << n;
            EXPECT_NEAR(s.run.y[n], y_line + r * std::sin(a), tol) << n;
        }
    }
}

TEST(LineSweep, ExtremeShapesStayWithinTheReachWithoutJumps) {
    // Narrow and tall, wide and flat, the fastest retrace with long
    // turnarounds, a single line: the path stays within the reach (the
    // integer path's range, 2^31 LSB) and moves no more than its fastest
    // sweep a tick (the staircase's step: 15/8 dy / T).
    struct Shape {
        float w, h, k, turn_s, rate;
        uint32_t lines;
        bool bi;
        SlowAxis slow;
    };
    const Shape shapes[] = {
        {0.1f, 100.0f, 1.0f, 0.0005f, 200.0f, 6, false, SlowAxis::kStaircase},
        {0.1f, 100.0f, 1.0f, 0.0005f, 200.0f, 6, true, SlowAxis::kRamp},
        {100.0f, 0.1f, 16.0f, 0.0005f, 50.0f, 6, false, SlowAxis::kStaircase},
        {20.0f, 20.0f, 16.0f, 0.0005f, 100.0f, 3, false, SlowAxis::kRamp},
        {20.0f, 5.0f, 4.0f, 0.0005f, 100.0f, 1, false, SlowAxis::kStaircase},
    };
    for (const Shape& sh : shapes) {
        ScanConfig c = raster();
        c.size_x_um = sh.w;
        c.size_y_um = sh.h;
        c.retrace_speed_factor = sh.k;
        c.turnaround_s = sh.turn_s;
        c.line_rate_Hz = sh.rate;
        c.lines_per_frame = sh.lines;
        c.bidirectional = sh.bi;
        c.slow_axis = sh.slow;
        c.pixels_per_line = 8;
        Sweep s(c);
        ASSERT_GT(s.run.size(), 0u);
        const double tol = 2.0 * noise(s.g, s.run), T = s.g.sweep_params().turn_ticks;
        const double dy = sh.lines > 1 ? sh.h / (sh.lines - 1) : 0.0;
        const double step_max = std::max({s.v_trace, s.v_retrace}) + tol;
        const double slow_max = std::max(15.0 / 8.0 * dy / T, 2.0 * sh.h / (s.frame + 1.0)) + tol;
        for (std::size_t n = 0; n < s.run.size(); ++n) {
            ASSERT_LE(std::fabs(s.run.x[n]) + std::fabs(s.run.y[n]), s.g.reach_um()) << sh.w << " " << n;
            if (n == 0) continue;
            ASSERT_LE(std::fabs(s.run.x[n] - s.run.x[n - 1]), step_max) << sh.w << " " << n;
            ASSERT_LE(std::fabs(s.run.y[n] - s.run.y[n - 1]), slow_max) << sh.w << " " << n;
        }
        EXPECT_EQ(s.run.ticks_with(piezoloop::kSyncPixel).size(), std::size_t{8} * sh.lines * c.frames);
        if (sh.lines == 1) {
            EXPECT_EQ(s.run.y[s.lead], 0.0);
        }
    }
}

TEST(LineSweep, SineFastAxisUsesTheMiddleAndStepsOutsideIt) {
    // x = -A cos(pi k / half), A = W/2 (1 + 2 overscan): the pixels span
    // |x| <= W/2 (to a tick's travel, pi A / half at most), evenly in time;
    // the staircase moves only outside the used part; the scan starts and
    // ends at rest at a turning point, with no lead-in.
    for (const bool bidirectional : {false, true}) {
        ScanConfig c = raster();
        c.fast_axis = piezoloop::FastAxis::kSine;
        c.bidirectional = bidirectional;
        Sweep s(c);
        const auto& p = s.g.sweep_params();
        const double A = 0.5 * c.size_x_um * (1.0 + 2.0 * c.overscan_fraction);
        const double tick_travel = M_PI * A / p.cv_ticks, tol = 2.0 * noise(s.g, s.run);
        EXPECT_EQ(s.lead, 0u);
        EXPECT_NEAR(s.run.x[0], -A, tol);
        EXPECT_EQ(s.line, bidirectional ? p.cv_ticks : 2 * p.cv_ticks);
        EXPECT_EQ(s.run.size(), std::size_t{c.frames} * s.frame);
        const auto lines = s.run.ticks_with(piezoloop::kSyncLineStart);
        const auto pixels = s.run.ticks_with(piezoloop::kSyncPixel);
        ASSERT_EQ(lines.size(), std::size_t{c.frames} * c.lines_per_frame);
        ASSERT_EQ(pixels.size(), lines.size() * c.pixels_per_line);
        for (std::size_t l = 0; l < lines.size(); ++l) {
            const double dir = bidirectional && l % 2 == 1 ? -1.0 : 1.0;
            const std::size_t first = pixels[l * c.pixels_per_line];
            EXPECT_EQ(first, lines[l] + p.overscan_ticks);
            EXPECT_NEAR(dir * s.run.x[first], -0.5 * c.size_x_um, tick_travel);
            EXPECT_NEAR(dir * s.run.x[first + p.used_ticks], 0.5 * c.size_x_um, tick_travel);
            for (std::size_t k = 0; k <= p.used_ticks; ++k) {
                ASSERT_EQ(s.run.y[first + k], s.run.y[first]) << l << " " << k;  // no step in the used part
                ASSERT_LE(std::fabs(s.run.x[first + k]), 0.5 * c.size_x_um + tick_travel);
            }
        }
        const std::size_t e = s.run.size() - 1;
        EXPECT_NEAR(std::fabs(s.run.x[e]), A, tick_travel);
        EXPECT_TRUE(s.g.done());
    }
}
