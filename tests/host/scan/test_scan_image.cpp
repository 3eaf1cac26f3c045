// Pixels, images and figures of a scan against closed forms, on records
// made from the scan generator alone (no stage): an ideal stage (true =
// measured = commanded) has no tracking error, images the grating's pitch
// exactly (the pitch a whole number of pixels, so every period's crossings
// err alike), uses P L of each line's ticks and takes the generator's frame
// period; a stage lagging the command by one pixel's L ticks has the error
// v L = one pixel width in x, none in y, and shows the grating one pixel
// width further along x in the commanded image than in the measured one.
#include <gtest/gtest.h>

#include <cmath>
#include <vector>

#include "piezoloop/scan/scan_generator.hpp"
#include "scan/grating_pitch.hpp"
#include "scan/sample_spec.hpp"
#include "scan/scan_image.hpp"
#include "scan/scan_metrics.hpp"
#include "scan/scan_pixels.hpp"

using namespace piezoloop;
using namespace piezoloop::scan;

namespace {

constexpr double kRate_Hz = 100000.0;
constexpr int kPixels = 64, kLines = 8;
constexpr double kWidth_um = 16.0, kPixel_um = kWidth_um / kPixels;  // 0.25 µm: 8 pixels a period

ScanConfig raster() {
    ScanConfig c;
    c.sample_rate_Hz = static_cast<float>(kRate_Hz);
    c.centre_x_um = 0.0123f;  // no sample exactly on an edge of the grating
    c.centre_y_um = 1.0f;
    c.size_x_um = static_cast<float>(kWidth_um);
    c.size_y_um = 4.0f;
    c.pixels_per_line = kPixels;
    c.lines_per_frame = kLines;
    c.line_rate_Hz = 50.0f;
    c.frames = 2;
    return c;
}

// The generator's ticks, the stage `lag` ticks behind the command (before
// the first tick it rests at the first point), the probe on a 2 µm grating.
std::vector<ScanTick> record(int lag, ScanGenerator<float>& g) {
    EXPECT_TRUE(g.configure(raster()).ok());
    const SampleSurface grating = parse_sample_spec("grating:pitch=2,height_nm=50");
    std::vector<ScanPoint<float>> cmd;
    while (!g.done()) cmd.push_back(g.step());
    std::vector<ScanTick> ticks(cmd.size());
    for (std::size_t k = 0; k < cmd.size(); ++k) {
        const ScanPoint<float>& at = cmd[k >= static_cast<std::size_t>(lag) ? k - lag : 0];
        ScanTick& t = ticks[k];
        t.commanded_x_um = cmd[k].x;
        t.commanded_y_um = cmd[k].y;
        t.true_x_um = t.measured_x_um = at.x;
        t.true_y_um = t.measured_y_um = at.y;
        t.height_nm = grating.height_at_nm(t.true_x_um, t.true_y_um);
        t.sync = cmd[k].sync;
    }
    return ticks;
}

ImageGrid image(const std::vector<ScanPixel>& px, Placement where, Quantity what = Quantity::kHeight) {
    ImageGrid g = raster_grid(px, 0);
    place_by_lines(g, px, 0, where, what);
    return g;
}

}  // namespace

TEST(ScanImage, IdealStage) {
    ScanGenerator<float> gen;
    const std::vector<ScanTick> ticks = record(0, gen);
    const std::vector<ScanPixel> px = form_pixels(ticks);
    const uint32_t L = usual_pixel_ticks(ticks);
    ASSERT_GT(L, 1u);
    ASSERT_EQ(px.size(), std::size_t{2} * kLines * kPixels);
    for (const ScanPixel& p : px) EXPECT_EQ(p.ticks, L);
    EXPECT_EQ(px.back().frame, 1u);
    EXPECT_EQ(px.back().line, kLines - 1u);
    EXPECT_EQ(px.back().index, kPixels - 1u);

    const ScanMetrics m = compute_metrics(ticks, px, kRate_Hz, true);
    EXPECT_EQ(m.tracking.rms_x_um, 0.0);
    EXPECT_EQ(m.tracking.max_x_um, 0.0);
    EXPECT_EQ(m.tracking.rms_y_um, 0.0);
    EXPECT_EQ(m.tracking.used_ticks, px.size() * L);
    // The last of the two frames: half the pixels.
    EXPECT_EQ(m.last_frame_index, 1u);
    EXPECT_EQ(m.last_frame.used_ticks, px.size() / 2 * L);
    EXPECT_EQ(m.last_frame.rms_x_um, 0.0);
    EXPECT_EQ(m.lines, std::size_t{2} * kLines);
    // Every line but the frames' last two (the frame turns there) lasts the
    // line period; within 1 / lines of the closed form.
    const double used = static_cast<double>(kPixels * L) / gen.line_period_ticks();
    EXPECT_NEAR(m.used_fraction, used, used / kLines);
    EXPECT_DOUBLE_EQ(m.frame_time_s, gen.frame_period_ticks() / kRate_Hz);
    EXPECT_LT(m.linearity_um, 1e-5);  // float positions: a few ulp of 8 µm

    const ImageGrid grid = raster_grid(px, 0);
    EXPECT_NEAR(grid.dx_um, kPixel_um, 1e-6);  // float positions
    for (Placement where : {Placement::kCommanded, Placement::kMeasured}) {
        const GratingFit f = fit_grating(image(px, where));
        EXPECT_NEAR(f.pitch_um, 2.0, 2e-6) << "float positions: 1e-6 relative";
        EXPECT_EQ(f.rows, static_cast<std::size_t>(kLines));
        EXPECT_GE(f.crossings, 7u * kLines);
    }
    // The cells' placement sees the same pixels.
    ImageGrid cells = area_grid(0.0123, 1.0, kWidth_um, 4.0 + 4.0 / (kLines - 1), kPixels, kLines);
    place_by_cells(cells, px, 0, Placement::kMeasured, Quantity::kHeight);
    EXPECT_NEAR(fit_grating(cells).pitch_um, 2.0, 2e-6);
    // Error maps: zero where a pixel is.
    for (const double e : image(px, Placement::kCommanded, Quantity::kErrorX).value)
        if (std::isfinite(e)) {
            EXPECT_EQ(e, 0.0);
        }
}

TEST(ScanImage, ConstantLagShiftsTheCommandedImage) {
    ScanGenerator<float> gen;
    const std::vector<ScanTick> ideal = record(0, gen);
    const uint32_t L = usual_pixel_ticks(ideal);
    const std::vector<ScanTick> ticks = record(static_cast<int>(L), gen);
    const std::vector<ScanPixel> px = form_pixels(ticks);
    const ScanMetrics m = compute_metrics(ticks, px, kRate_Hz, true);
    // v L = (width / (P L)) L = one pixel width, float positions: 1e-5 µm.
    EXPECT_NEAR(m.tracking.rms_x_um, kPixel_um, 1e-5);
    EXPECT_NEAR(m.tracking.max_x_um, kPixel_um, 1e-5);
    EXPECT_EQ(m.tracking.max_y_um, 0.0);
    EXPECT_NEAR(m.last_frame.rms_x_um, kPixel_um, 1e-5);  // the lag is the same in every frame
    EXPECT_LT(m.linearity_um, 1e-5);

    const GratingFit commanded = fit_grating(image(px, Placement::kCommanded));
    const GratingFit measured = fit_grating(image(px, Placement::kMeasured));
    EXPECT_NEAR(commanded.pitch_um, 2.0, 2e-6);
    EXPECT_NEAR(measured.pitch_um, 2.0, 2e-6);
    EXPECT_NEAR(commanded.phase_um - measured.phase_um, kPixel_um, 1e-5);
    // The measured image is the ideal stage's image: same edges.
    const GratingFit ideal_fit = fit_grating(image(form_pixels(ideal), Placement::kMeasured));
    EXPECT_NEAR(measured.phase_um, ideal_fit.phase_um, 1e-5);
    // The error map shows the lag.
    for (const double e : image(px, Placement::kCommanded, Quantity::kErrorX).value)
        if (std::isfinite(e)) {
            EXPECT_NEAR(e, kPixel_um, 1e-5);
        }
}
