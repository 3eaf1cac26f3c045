// The exact sampled transfer matrix of a linear stage of coupled axes
// (sim/exact_transfer.hpp) against scipy's (tools/ref/coupled_stage_ref.py,
// each continuous block discretised on its own by scipy.signal.cont2discrete
// in well-scaled state space), and its refusals.
#include <gtest/gtest.h>

#include <cmath>
#include <complex>

#include "coupled_stage_fixture.hpp"
#include "sim/exact_transfer.hpp"
#include "test_support.hpp"

using namespace piezoloop;
using namespace piezoloop::sim;

// Both sides in double from the same continuous parameters, by different
// routes (host: c2d of the zpk, zpk2sos, sections evaluated in z; scipy:
// expm of the state space): they agree to rounding, amplified at most by the
// poles' distance to the unit circle (0.004 at the 750 Hz, zeta 0.02 mode)
// and the sampling zeros' near z = -1 at the top frequencies. 1e-9 of each
// entry leaves three or more orders of magnitude for that; a path that does
// not exist (z -> x, z -> y) is exactly 0 on both sides.
TEST(ExactTransfer, XyzFlexureEqualsScipyTo1e9) {
    const nlohmann::json ref = test::load_golden("coupled_stage_ref");
    const Scenario s = test::linear_xyz_flexure(ref);
    ASSERT_EQ(s.axes.size(), 3u);
    const std::vector<double> freqs = ref["frequencies_Hz"].get<std::vector<double>>();
    ASSERT_GE(freqs.size(), 30u);
    double worst = 0.0;
    for (size_t k = 0; k < freqs.size(); ++k) {
        const TransferMatrix g = exact_transfer_matrix(s, freqs[k]);
        ASSERT_EQ(g.size(), 3u);
        for (size_t i = 0; i < 3; ++i)
            for (size_t j = 0; j < 3; ++j) {
                const auto& r = ref["transfer"][k][i][j];
                const std::complex<double> want(r[0].get<double>(), r[1].get<double>());
                if (want == 0.0) {
                    EXPECT_EQ(g[i][j], 0.0) << freqs[k] << " Hz, G" << i << j;
                    continue;
                }
                const double rel = std::abs(g[i][j] - want) / std::abs(want);
                worst = std::max(worst, rel);
                EXPECT_LT(rel, 1e-9) << freqs[k] << " Hz, G" << i << j << ": " << g[i][j] << " vs " << want;
            }
    }
    std::printf("worst relative error: %.3g\n", worst);
}

// The DC gains and the -20 dB coupling at the source's mode, from the
// parameters alone: G_yx(0) = 3 % of G_xx(0); at 750 Hz the x -> y path is
// 0.03 / (2 x 0.15) = 10 % of the direct response (its own discretisation
// and the sensor lags cancel in the ratio).
TEST(ExactTransfer, CouplingSizesAsSpecified) {
    const nlohmann::json ref = test::load_golden("coupled_stage_ref");
    const Scenario s = test::linear_xyz_flexure(ref);
    const TransferMatrix dc = exact_transfer_matrix(s, 0.0);
    const double gx = ref["linear_gain_um_per_V"][0].get<double>() * 15.0;
    EXPECT_NEAR(dc[0][0].real(), gx, 1e-12 * gx);
    EXPECT_NEAR(dc[1][0].real() / dc[0][0].real(), 0.03, 1e-12);
    EXPECT_NEAR(dc[0][1].real() / dc[1][1].real(), 0.025, 1e-12);
    EXPECT_NEAR(dc[2][1].real() / dc[1][1].real(), 0.012, 1e-12);
    const TransferMatrix m = exact_transfer_matrix(s, 750.0);
    const double ratio_dB = 20.0 * std::log10(std::abs(m[1][0] / m[0][0]));
    EXPECT_NEAR(ratio_dB, -20.0, 0.3);
}

TEST(ExactTransfer, RefusesStagesThatAreNotLinear) {
    const Scenario hysteretic = load_scenario(test::configs_dir() + "stages/xyz_flexure.json");
    EXPECT_EQ(test::error_of([&] { (void)exact_transfer_matrix(hysteretic, 100.0); }),
              "plant.axes[0].hysteresis: the exact transfer matrix needs a linear stage: kind none (got pi)");
    const Scenario creeping = load_scenario(test::configs_dir() + "stages/drifting_stage.json");
    Scenario linear = creeping;
    linear.plant.hysteresis = HysteresisSpec{};
    EXPECT_NE(test::error_of([&] { (void)exact_transfer_matrix(linear, 100.0); }).find("plant.creep: "), std::string::npos);
    const nlohmann::json ref = test::load_golden("coupled_stage_ref");
    const Scenario s = test::linear_xyz_flexure(ref);
    EXPECT_NE(test::error_of([&] { (void)exact_transfer_matrix(s, 10000.1); }).find("f_Hz: must be in [0, rate / 2]"),
              std::string::npos);
    EXPECT_NE(test::error_of([&] { (void)exact_transfer_matrix(s, -1.0); }), "");
}
