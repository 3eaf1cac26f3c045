// The Lissajous scan (through the generator, float) against its closed
// form with exact rational phases, its frame period 1 / gcd(f_x, f_y), its
// coverage of a pixel grid against tools/ref/scan_ref.py, and its events.
#include <gtest/gtest.h>

#include <cmath>
#include <cstdint>
#include <numeric>
#include <algorithm>
#include <set>
#include <utility>

#include "piezoloop/scan/scan_generator.hpp"
#include "scan_fixture.hpp"

using piezoloop::ScanConfig;
using piezoloop::ScanGenerator;
using piezoloop::test::float_ulp;
using piezoloop::test::run_scan;
using piezoloop::test::scan_case;
using piezoloop::test::scan_config_of;
using piezoloop::test::ScanRun;

namespace {

// Visited cells of a G x G grid over [-A, A] x [-B, B], as a share.
double coverage(const ScanRun& r, std::size_t ticks, double A, double B, int G) {
    std::set<std::pair<int, int>> cells;
    for (std::size_t n = 0; n < ticks; ++n) {
        const int i = std::clamp(static_cast<int>(std::floor((r.x[n] + A) / (2 * A) * G)), 0, G - 1);
        const int j = std::clamp(static_cast<int>(std::floor((r.y[n] + B) / (2 * B) * G)), 0, G - 1);
        cells.insert({i, j});
    }
    return static_cast<double>(cells.size()) / (G * G);
}

}  // namespace

TEST(Lissajous, ClosedFormOverAFrameAndExactPeriod) {
    const nlohmann::json ref = scan_case("lissajous");
    ScanConfig c = scan_config_of(ref["config"]);
    c.frames = 2;
    ScanGenerator<float> g;
    ASSERT_TRUE(g.configure(c).ok());
    const ScanRun r = run_scan(g);
    const int64_t fs = 100000, fx = 23, fy = 19;
    const int64_t frame = fs / std::gcd(fx, fy);  // 1 / gcd(f_x, f_y) s
    ASSERT_EQ(g.frame_period_ticks(), static_cast<uint32_t>(frame));
    ASSERT_EQ(r.size(), 2 * static_cast<std::size_t>(frame));
    const double A = 0.5 * c.size_x_um, B = 0.5 * c.size_y_um;
    // The sine table (2.95e-7 of the amplitude), the phase rounded up to
    // 2^-32 cycle (2 pi 2^-32 of it), a few LSB of the reach, 2 float ulp.
    const double tol = (A + B) * (2.95e-7 + 2.0 * M_PI * 0x1p-32 + 4.0 * 0x1p-31) + 2.0 * float_ulp(A + B);
    for (int64_t n = 0; n < frame; ++n) {
        const double px = static_cast<double>((n * fx) % fs) / fs, py = static_cast<double>((n * fy) % fs) / fs;
        ASSERT_NEAR(r.x[n], A * std::sin(2.0 * M_PI * px), tol) << n;
        ASSERT_NEAR(r.y[n], B * std::sin(2.0 * M_PI * (py + 0.25)), tol) << n;
        // Periodic to the bit.
        ASSERT_EQ(r.x[n + frame], r.x[n]);
        ASSERT_EQ(r.y[n + frame], r.y[n]);
    }
    // Held at the frame's start afterwards.
    const auto hold = g.step();
    EXPECT_EQ(hold.x, r.x[0]);
    EXPECT_EQ(hold.y, r.y[0]);
}

TEST(Lissajous, CoverageAsTheReferenceStates) {
    // 23 : 19 Hz over a 64 x 64 grid: 79.6 % of the cells in a frame
    // (scan_ref.py, from the closed form). A sample within ~1e-6 um of a
    // cell edge may land in the neighbour cell: allowed 2 cells of 4096.
    const nlohmann::json ref = scan_case("lissajous");
    const ScanConfig c = scan_config_of(ref["config"]);
    ScanGenerator<float> g;
    ASSERT_TRUE(g.configure(c).ok());
    const ScanRun r = run_scan(g);
    const int G = ref["derived"]["coverage_grid"];
    const double want = ref["derived"]["coverage"];
    EXPECT_NEAR(want, 0.796, 0.001);
    EXPECT_NEAR(coverage(r, r.size(), 0.5 * c.size_x_um, 0.5 * c.size_y_um, G), want, 2.0 / (G * G));
}

TEST(Lissajous, LinesAreHalfPeriodsOfXWithPPixels) {
    const nlohmann::json ref = scan_case("lissajous");
    const ScanConfig c = scan_config_of(ref["config"]);
    ScanGenerator<float> g;
    ASSERT_TRUE(g.configure(c).ok());
    const ScanRun r = run_scan(g);
    const auto lines = r.ticks_with(piezoloop::kSyncLineStart);
    const auto pixels = r.ticks_with(piezoloop::kSyncPixel);
    EXPECT_EQ(g.lines_per_frame(), 2u * 23u);
    ASSERT_EQ(lines.size(), 2u * 23u);
    EXPECT_EQ(pixels.size(), lines.size() * c.pixels_per_line);
    const double A = 0.5 * c.size_x_um;
    for (std::size_t l = 0; l + 1 < lines.size(); ++l) {
        const auto in_line = std::count_if(pixels.begin(), pixels.end(),
                                           [&](std::size_t t) { return t >= lines[l] && t < lines[l + 1]; });
        EXPECT_EQ(in_line, c.pixels_per_line) << l;
        // A line starts at an x extreme (within a tick's motion there).
        EXPECT_NEAR(std::fabs(r.x[lines[l]]), A, A * 1e-5) << l;
    }
}

// A float cannot hold f_s / 85 exactly; within its rounding the sinusoid is
// taken to repeat after 85 ticks, so the frame is lcm(80, 85) = 1360 ticks
// (the nearest rational of the float itself would need ~2^28). Each axis's
// own period is then whole; a y at 250 * 63 / 64 Hz (exact in float, 81.27
// ticks) is not, and its axis learns over the frame, 64 periods of x.
TEST(Lissajous, AxisPeriodsInWholeTicks) {
    ScanConfig c;
    c.pattern = piezoloop::ScanPattern::kLissajous;
    c.sample_rate_Hz = 20000.0f;
    c.size_x_um = c.size_y_um = 20.0f;
    c.pixels_per_line = 16;
    c.frequency_x_Hz = 250.0f;
    c.frequency_y_Hz = static_cast<float>(20000.0 / 85.0);
    ASSERT_NE(static_cast<double>(c.frequency_y_Hz) * 85.0, 20000.0);
    ScanGenerator<float> g;
    ASSERT_TRUE(g.configure(c).ok());
    EXPECT_EQ(g.frame_period_ticks(), 1360u);
    EXPECT_EQ(g.lissajous_axis_period_ticks(0), 80u);
    EXPECT_EQ(g.lissajous_axis_period_ticks(1), 85u);
    const ScanRun r = run_scan(g);
    for (std::size_t n = 0; n + 85 < r.y.size(); ++n) ASSERT_EQ(r.y[n], r.y[n + 85]) << n;

    c.frequency_y_Hz = 250.0f * 63.0f / 64.0f;
    ASSERT_TRUE(g.configure(c).ok());
    EXPECT_EQ(g.frame_period_ticks(), 64u * 80u);
    EXPECT_EQ(g.lissajous_axis_period_ticks(0), 80u);
    EXPECT_EQ(g.lissajous_axis_period_ticks(1), 64u * 80u);
}
