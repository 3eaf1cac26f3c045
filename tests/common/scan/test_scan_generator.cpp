// The scan generator against tools/ref/scan_ref.py (tests/golden/scan_ref.json:
// numpy positions, exact-arithmetic events), the float and Q31 generators
// against each other, rotation, the start point, and refused configurations.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <string>
#include <vector>

#include "piezoloop/scan/scan_generator.hpp"
#include "scan_fixture.hpp"

using piezoloop::Q31;
using piezoloop::ScanConfig;
using piezoloop::ScanGenerator;
using piezoloop::ScanPattern;
using piezoloop::ScanPoint;
using piezoloop::SignalScale;
using piezoloop::SpiralMode;
using piezoloop::test::float_ulp;
using piezoloop::test::run_scan;
using piezoloop::test::scan_case;
using piezoloop::test::scan_config_of;
using piezoloop::test::ScanRun;

namespace {

constexpr double kSineErr = 2.95e-7;  // sine_table.hpp's bound, of the amplitude
constexpr double kLsb = 0x1p-31;

// What a case's reference allows, in µm: the pattern's sine (kSineErr of the
// reach) and the rotation's cos and sin (kSineErr each), a few LSB of the
// reach from the integer path's roundings, and 2 float ulp of the largest
// coordinate. The CLV spiral adds its root: 5e-7 relative in q = r / R
// moves the angle by 2 pi K 5e-7 (fixed_sqrt.hpp).
double golden_tolerance(const ScanGenerator<float>& g, const ScanConfig& c) {
    const double reach = g.reach_um();
    double tol = reach * (3.0 * kSineErr + 8.0 * kLsb) +
                 2.0 * float_ulp(std::max(std::fabs(c.centre_x_um), std::fabs(c.centre_y_um)) + reach);
    if (c.pattern == ScanPattern::kSpiral && c.spiral_mode == SpiralMode::kConstantLinearVelocity)
        tol += reach * (2.0 * M_PI * c.turns + 1.0) * 5e-7;
    return tol;
}

std::vector<std::size_t> as_ticks(const nlohmann::json& j) {
    std::vector<std::size_t> t;
    for (const auto& v : j) t.push_back(v.get<std::size_t>());
    return t;
}

class ScanGolden : public ::testing::TestWithParam<const char*> {};

}  // namespace

TEST_P(ScanGolden, PositionsAndEventsMatchTheReference) {
    const nlohmann::json ref = scan_case(GetParam());
    ASSERT_FALSE(ref.is_null()) << GetParam();
    const ScanConfig c = scan_config_of(ref["config"]);
    ScanGenerator<float> g;
    const auto s = g.configure(c);
    ASSERT_TRUE(s.ok()) << s.field << ": " << s.message;
    const ScanRun run = run_scan(g, ref["ticks"].get<std::size_t>());
    ASSERT_EQ(run.size(), ref["ticks"].get<std::size_t>());

    const double tol = golden_tolerance(g, c);
    const std::size_t stride = ref["stride"];
    double worst = 0.0;
    for (std::size_t i = 0; i < ref["x_um"].size(); ++i) {
        const std::size_t n = i * stride;
        const double ex = std::fabs(run.x[n] - ref["x_um"][i].get<double>());
        const double ey = std::fabs(run.y[n] - ref["y_um"][i].get<double>());
        worst = std::max({worst, ex, ey});
        ASSERT_LE(ex, tol) << "x at tick " << n;
        ASSERT_LE(ey, tol) << "y at tick " << n;
    }
    RecordProperty("worst_um", std::to_string(worst * 1e6) + " pm");
    RecordProperty("tolerance_um", std::to_string(tol * 1e6) + " pm");
    EXPECT_EQ(g.frame_period_ticks(), ref["derived"]["frame_ticks"].get<uint32_t>());

    // Events: exactly the reference's ticks.
    EXPECT_EQ(run.ticks_with(piezoloop::kSyncFrameStart), as_ticks(ref["events"]["frame"]));
    if (c.pattern == ScanPattern::kSpiral && c.spiral_mode == SpiralMode::kConstantLinearVelocity) return;
    EXPECT_EQ(run.ticks_with(piezoloop::kSyncLineStart), as_ticks(ref["events"]["line"]));
    std::vector<std::size_t> pixels = run.ticks_with(piezoloop::kSyncPixel);
    const std::vector<std::size_t> want = as_ticks(ref["events"]["pixel"]);
    if (c.pattern == ScanPattern::kLissajous) {
        EXPECT_EQ(pixels.size(), ref["derived"]["pixel_events"].get<std::size_t>());
        pixels.resize(std::min(pixels.size(), want.size()));
    }
    EXPECT_EQ(pixels, want);
}

INSTANTIATE_TEST_SUITE_P(Cases, ScanGolden,
                         ::testing::Values("raster_unidirectional_staircase", "raster_bidirectional_ramp_rotated",
                                           "cycloid", "spiral_cav", "spiral_clv", "lissajous"));
