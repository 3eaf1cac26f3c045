// The scan generator against tools/ref/scan_ref.py (tests/golden/scan_ref.json:
// numpy positions, exact-arithmetic events), the float and Q31 generators
// against each other, rotation, the start point, and refused configurations.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <string>
#include <vector>

#include "piezoloop/approach.hpp"
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
                                           "raster_sine_unidirectional_staircase",
                                           "raster_sine_bidirectional_staircase_rotated",
                                           "cycloid", "spiral_cav", "spiral_clv", "lissajous"));

// ---- float and Q31 ------------------------------------------------------------

TEST_P(ScanGolden, FloatAndQ31Agree) {
    // Both share the integer path (Q31 of the reach, rotated in integers);
    // they differ by the last step: float centre + reach * u (2 float ulp),
    // Q31 centre + (reach / fs) * u (the Q31 multiply's rounding and the
    // reach's and centre's quantisation: 3 LSB of the full scale).
    const nlohmann::json ref = scan_case(GetParam());
    const ScanConfig c = scan_config_of(ref["config"]);
    const SignalScale fs_x{40.0f}, fs_y{30.0f}, fs_z{20.0f};
    ScanGenerator<float> gf;
    ScanGenerator<Q31> gq(fs_x, fs_y, fs_z);
    ASSERT_TRUE(gf.configure(c).ok());
    const auto s = gq.configure(c);
    ASSERT_TRUE(s.ok()) << s.field << ": " << s.message;
    const std::size_t ticks = ref["ticks"];
    const ScanRun rf = run_scan(gf, ticks);
    const ScanRun rq = run_scan(gq, ticks, fs_x, fs_y, fs_z);
    const double tol_x = 3.0 * 40.0 * kLsb + 2.0 * float_ulp(40.0), tol_y = 3.0 * 30.0 * kLsb + 2.0 * float_ulp(30.0);
    for (std::size_t n = 0; n < ticks; ++n) {
        ASSERT_NEAR(rf.x[n], rq.x[n], tol_x) << n;
        ASSERT_NEAR(rf.y[n], rq.y[n], tol_y) << n;
        ASSERT_EQ(rf.sync[n], rq.sync[n]) << n;
    }
}

// ---- rotation, centre, hold, start ------------------------------------------------

TEST(ScanGenerator, RotationAboutTheCentrePreservesDistances) {
    // The same raster at 0 and at 37 degrees about (3, -2): every point is
    // the unrotated one turned about the centre, and every step (and every
    // distance to the first point) keeps its length. cos and sin come from
    // the sine table (2.95e-7 each), so lengths agree to 6e-7 of the reach
    // plus the positions' noise.
    const nlohmann::json ref = scan_case("raster_unidirectional_staircase");
    ScanConfig c = scan_config_of(ref["config"]);
    c.frames = 1;
    ScanGenerator<float> g0, g1;
    ASSERT_TRUE(g0.configure(c).ok());
    c.rotation_deg = 37.0f;
    c.centre_x_um = 3.0f;
    c.centre_y_um = -2.0f;
    c.hold_z_um = 1.5f;
    ASSERT_TRUE(g1.configure(c).ok());
    const ScanRun a = run_scan(g0), b = run_scan(g1);
    ASSERT_EQ(a.size(), b.size());
    const double reach = g0.reach_um();
    const double tol = reach * (6e-7 + 8.0 * kLsb) + 4.0 * float_ulp(3.0 + reach);
    const double th = 37.0 * M_PI / 180.0;
    for (std::size_t n = 0; n < a.size(); ++n) {
        ASSERT_NEAR(b.x[n], 3.0 + std::cos(th) * a.x[n] - std::sin(th) * a.y[n], tol) << n;
        ASSERT_NEAR(b.y[n], -2.0 + std::sin(th) * a.x[n] + std::cos(th) * a.y[n], tol) << n;
        ASSERT_EQ(b.z[n], 1.5);
        ASSERT_EQ(a.sync[n], b.sync[n]);
        if (n == 0) continue;
        const double da = std::hypot(a.x[n] - a.x[0], a.y[n] - a.y[0]);
        const double db = std::hypot(b.x[n] - b.x[0], b.y[n] - b.y[0]);
        ASSERT_NEAR(db, da, 2.0 * tol) << n;
        const double sa = std::hypot(a.x[n] - a.x[n - 1], a.y[n] - a.y[n - 1]);
        const double sb = std::hypot(b.x[n] - b.x[n - 1], b.y[n] - b.y[n - 1]);
        ASSERT_NEAR(sb, sa, 2.0 * tol) << n;
    }
}

TEST(ScanGenerator, StartPointIsTheFirstTickAndAnApproachEndsThere) {
    const SignalScale fs{40.0f};
    for (const char* name : {"raster_unidirectional_staircase", "cycloid", "spiral_cav", "lissajous"}) {
        const ScanConfig c = scan_config_of(scan_case(name)["config"]);
        ScanGenerator<Q31> g(fs, fs, fs);
        ASSERT_TRUE(g.configure(c).ok()) << name;
        const ScanPoint<Q31> start = g.start_point();
        // The approach (approach.hpp) from elsewhere ends on the start point.
        piezoloop::Approach<Q31> ax(fs, c.sample_rate_Hz);
        const Q31 from = Q31::from_float(0.3f);
        Q31 last = from;
        if (ax.begin(from, start.x)) {
            while (ax.moving()) last = ax.step();
            EXPECT_LE(std::abs(int64_t{last.raw()} - start.x.raw()), static_cast<int64_t>(ax.unit()) + 1) << name;
        }
        const ScanPoint<Q31> first = g.step();
        EXPECT_EQ(first.x, start.x) << name;
        EXPECT_EQ(first.y, start.y) << name;
        EXPECT_TRUE(first.sync & piezoloop::kSyncFrameStart || c.pattern == ScanPattern::kRaster ||
                    c.pattern == ScanPattern::kCycloid) << name;  // the raster's lead-in comes first
        g.step();
        EXPECT_EQ(g.start_point().x, start.x) << name;  // no state change, any time
    }
}

// ---- refused configurations ----------------------------------------------------------

TEST(ScanGenerator, RefusedConfigurationsNameTheFieldAndChangeNothing) {
    const ScanConfig good = scan_config_of(scan_case("raster_unidirectional_staircase")["config"]);
    struct Case {
        const char* field;
        ScanConfig c;
    };
    std::vector<Case> cases;
    auto with = [&](const char* field, auto edit) {
        ScanConfig c = good;
        edit(c);
        cases.push_back({field, c});
    };
    with("sample_rate_Hz", [](ScanConfig& c) { c.sample_rate_Hz = 0.0f; });
    with("sample_rate_Hz", [](ScanConfig& c) { c.sample_rate_Hz = NAN; });
    with("centre_x_um", [](ScanConfig& c) { c.centre_x_um = INFINITY; });
    with("centre_y_um", [](ScanConfig& c) { c.centre_y_um = 2e6f; });
    with("hold_z_um", [](ScanConfig& c) { c.hold_z_um = NAN; });
    with("rotation_deg", [](ScanConfig& c) { c.rotation_deg = 400.0f; });
    with("pixels_per_line", [](ScanConfig& c) { c.pixels_per_line = 0; });
    with("pixels_per_line", [](ScanConfig& c) { c.pixels_per_line = 4096; });  // more than the trace's ticks
    with("pattern", [](ScanConfig& c) { c.pattern = static_cast<ScanPattern>(9); });
    with("size_x_um", [](ScanConfig& c) { c.size_x_um = 0.0f; });
    with("size_y_um", [](ScanConfig& c) { c.size_y_um = -1.0f; });
    with("lines_per_frame", [](ScanConfig& c) { c.lines_per_frame = 0; });
    with("lines_per_frame", [](ScanConfig& c) { c.lines_per_frame = 65536; c.line_rate_Hz = 1.0f; c.pixels_per_line = 1; });
    with("line_rate_Hz", [](ScanConfig& c) { c.line_rate_Hz = 25000.0f; });  // the loop rate / 4
    with("retrace_speed_factor", [](ScanConfig& c) { c.retrace_speed_factor = 0.5f; });
    with("retrace_speed_factor", [](ScanConfig& c) { c.retrace_speed_factor = 16.0f; c.turnaround_s = 0.002f; c.pixels_per_line = 1; c.line_rate_Hz = 40.0f; });
    with("overscan_fraction", [](ScanConfig& c) { c.overscan_fraction = 1.5f; });
    with("turnaround_s", [](ScanConfig& c) { c.turnaround_s = 1e-5f; });
    with("turnaround_s", [](ScanConfig& c) { c.turnaround_s = 0.004f; });  // longer than the line allows
    with("slow_axis", [](ScanConfig& c) { c.slow_axis = static_cast<piezoloop::SlowAxis>(7); });
    with("fast_axis", [](ScanConfig& c) { c.fast_axis = static_cast<piezoloop::FastAxis>(3); });
    with("overscan_fraction", [](ScanConfig& c) { c.fast_axis = piezoloop::FastAxis::kSine; c.bidirectional = true; c.overscan_fraction = 0.0f; });
    with("pixels_per_line", [](ScanConfig& c) { c.fast_axis = piezoloop::FastAxis::kSine; c.pixels_per_line = 200; });
    with("line_rate_Hz", [](ScanConfig& c) { c.fast_axis = piezoloop::FastAxis::kSine; c.line_rate_Hz = 0.0f; });
    with("radius_um", [](ScanConfig& c) { c.pattern = ScanPattern::kSpiral; c.radius_um = 0.0f; });
    with("turns", [](ScanConfig& c) { c.pattern = ScanPattern::kSpiral; c.turns = 0; });
    with("turn_rate_Hz", [](ScanConfig& c) { c.pattern = ScanPattern::kSpiral; c.turn_rate_Hz = 30000.0f; });
    with("pixels_per_line", [](ScanConfig& c) { c.pattern = ScanPattern::kSpiral; c.turn_rate_Hz = 1000.0f; c.pixels_per_line = 51; });
    with("spiral_mode", [](ScanConfig& c) { c.pattern = ScanPattern::kSpiral; c.spiral_mode = static_cast<SpiralMode>(5); });
    with("linear_speed_um_s", [](ScanConfig& c) { c.pattern = ScanPattern::kSpiral; c.spiral_mode = SpiralMode::kConstantLinearVelocity; c.linear_speed_um_s = 0.0f; });
    with("linear_speed_um_s", [](ScanConfig& c) { c.pattern = ScanPattern::kSpiral; c.spiral_mode = SpiralMode::kConstantLinearVelocity; c.linear_speed_um_s = 1e6f; });
    with("frequency_x_Hz", [](ScanConfig& c) { c.pattern = ScanPattern::kLissajous; c.frequency_x_Hz = 25000.0f; });
    with("frequency_y_Hz", [](ScanConfig& c) { c.pattern = ScanPattern::kLissajous; c.frequency_y_Hz = -3.0f; });
    with("frequency_y_Hz", [](ScanConfig& c) { c.pattern = ScanPattern::kLissajous; c.frequency_x_Hz = 100.0f; c.frequency_y_Hz = 33.3f; });
    with("phase_y_deg", [](ScanConfig& c) { c.pattern = ScanPattern::kLissajous; c.phase_y_deg = NAN; });
    with("pixels_per_line", [](ScanConfig& c) { c.pattern = ScanPattern::kLissajous; c.frequency_x_Hz = 1000.0f; c.pixels_per_line = 26; });
    with("radius_um", [](ScanConfig& c) { c.pattern = ScanPattern::kCycloid; c.radius_um = NAN; });
    with("turns_per_line", [](ScanConfig& c) { c.pattern = ScanPattern::kCycloid; c.turns_per_line = 0; });
    with("turn_rate_Hz", [](ScanConfig& c) { c.pattern = ScanPattern::kCycloid; c.turn_rate_Hz = 0.0f; });

    ScanGenerator<float> g;
    ASSERT_TRUE(g.configure(good).ok());
    const ScanRun before = run_scan(g, 300);
    for (const Case& k : cases) {
        const auto s = g.configure(k.c);
        ASSERT_FALSE(s.ok()) << k.field;
        EXPECT_STREQ(s.field, k.field) << s.message;
        EXPECT_STREQ(s.group, "scan") << k.field;
        EXPECT_NE(s.message, nullptr);
    }
    // Nothing changed: the run carries on where it was, as an untouched one does.
    ScanGenerator<float> twin;
    ASSERT_TRUE(twin.configure(good).ok());
    run_scan(twin, 300);
    const ScanRun a = run_scan(g, 2000), b = run_scan(twin, 2000);
    EXPECT_EQ(a.x, b.x);
    EXPECT_EQ(a.y, b.y);
    EXPECT_EQ(a.sync, b.sync);
    EXPECT_EQ(before.x.size(), 300u);
}

TEST(ScanGenerator, Q31RefusesAScanBeyondTheFullScale) {
    const ScanConfig good = scan_config_of(scan_case("spiral_cav")["config"]);  // radius 5 um
    ScanGenerator<Q31> g(SignalScale{6.0f}, SignalScale{6.0f}, SignalScale{6.0f});
    ASSERT_TRUE(g.configure(good).ok());
    ScanConfig c = good;
    c.centre_x_um = 1.5f;  // 1.5 + 5 > 6
    EXPECT_STREQ(g.configure(c).field, "centre_x_um");
    c = good;
    c.centre_y_um = -1.5f;
    EXPECT_STREQ(g.configure(c).field, "centre_y_um");
    c = good;
    c.hold_z_um = 7.0f;
    EXPECT_STREQ(g.configure(c).field, "hold_z_um");
    EXPECT_EQ(g.config().centre_x_um, 0.0f);
}

TEST(ScanGenerator, RepetitivePeriodIsTheFastMotionsPeriod) {
    // Raster: x repeats every line (outside the lead-in and lead-out).
    const ScanConfig c = scan_config_of(scan_case("raster_unidirectional_staircase")["config"]);
    ScanGenerator<float> g;
    ASSERT_TRUE(g.configure(c).ok());
    const ScanRun r = run_scan(g);
    const std::size_t N = g.repetitive_period_ticks(), lead = g.lead_in_ticks();
    EXPECT_EQ(N, g.line_period_ticks());
    for (std::size_t n = lead; n + N < r.size() - g.sweep_params().turn_ticks; ++n) ASSERT_EQ(r.x[n + N], r.x[n]) << n;
}
