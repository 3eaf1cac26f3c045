// Hammerstein plant model: hysteresis then unit-DC-gain dynamics.
#include <gtest/gtest.h>

#include <cmath>
#include <complex>

#include "piezoloop/pi_inverse.hpp"
#include "piezoloop/plant.hpp"
#include "piezoloop/tustin.hpp"

using namespace piezoloop;

namespace {

PlantConfig pi_stage() {
    PlantConfig c;
    c.hysteresis = HysteresisKind::kPi;
    const float r[] = {0.0f, 1.0f, 2.0f, 3.0f, 4.0f};
    const float p[] = {0.6f, 0.15f, 0.12f, 0.1f, 0.08f};
    EXPECT_TRUE(pi_model_from_lists(r, p, 5, nullptr, c.pi).ok());
    c.sections = 1;
    EXPECT_TRUE(tustin(resonance(1e3, 0.05), 1e5, c.dynamics[0]).ok());
    return c;
}

}  // namespace

TEST(Plant, IsHysteresisThenDynamics) {
    // Reference: the PI model by its direct formula and the section as a
    // difference equation, both in double, composed in the Hammerstein order.
    // The float plant differs by rounding only: the section's poles sit at
    // |z| = 0.997, so state rounding (2^-24 of ~4 µm) is amplified by up to
    // ~1/(1 - |z|) = 320: 2e-4 µm.
    const PlantConfig c = pi_stage();
    HammersteinPlant plant;
    ASSERT_TRUE(plant.configure(c).ok());
    const SosSection& q = c.dynamics[0];
    double w[4] = {0, 0, 0, 0};
    double x1 = 0, x2 = 0, y1 = 0, y2 = 0, worst = 0;
    for (int k = 0; k < 50000; ++k) {
        const float v = static_cast<float>(4.0 * std::sin(2.0 * M_PI * k / 2000.0) * std::cos(k * 1e-4));
        double x = c.pi.p0 * static_cast<double>(v);
        for (int j = 0; j < c.pi.count; ++j) {
            const double r = c.pi.thresholds[static_cast<unsigned>(j)];
            w[j] = std::max(v - r, std::min(v + r, w[j]));
            x += c.pi.weights[static_cast<unsigned>(j)] * w[j];
        }
        const double y = q.b0 * x + q.b1 * x1 + q.b2 * x2 - q.a1 * y1 - q.a2 * y2;
        x2 = x1; x1 = x; y2 = y1; y1 = y;
        worst = std::max(worst, std::fabs(plant.step(v) - y));
    }
    EXPECT_LT(worst, 2e-4);
}

TEST(Plant, ResonancePeakIsOneOverTwoZeta) {
    // Linear plant (no hysteresis), resonance 1 kHz, zeta 0.05: the analytic
    // continuous peak is 1 / (2 zeta) = 10 at f_n. Tustin warps 1 kHz at
    // 100 kHz by (pi f/fs)^2/3 = 3e-4 relative; measured as the steady-state
    // amplitude of a sine at f_n: 1 % covers warping and the amplitude read.
    PlantConfig c;
    c.linear_gain_um_per_V = 2.0f;
    c.sections = 1;
    ASSERT_TRUE(tustin(resonance(1e3, 0.05), 1e5, c.dynamics[0]).ok());
    HammersteinPlant plant;
    ASSERT_TRUE(plant.configure(c).ok());
    double amp = 0.0;
    for (int k = 0; k < 200000; ++k) {
        const float y = plant.step(static_cast<float>(std::sin(2.0 * M_PI * k / 100.0)));
        if (k > 150000) amp = std::max(amp, std::fabs(static_cast<double>(y)));
    }
    EXPECT_NEAR(amp, 2.0 * 10.0, 0.2);
}

TEST(Plant, RejectsBadConfigAndKeepsOld) {
    HammersteinPlant plant;
    ASSERT_TRUE(plant.configure(pi_stage()).ok());
    PlantConfig bad = pi_stage();
    bad.sections = 7;
    EXPECT_STREQ(plant.configure(bad).field, "sections");
    bad = pi_stage();
    bad.dynamics[0].a2 = 1.2;
    EXPECT_STREQ(plant.configure(bad).group, "dynamics");
    bad = pi_stage();
    bad.pi.thresholds[1] = -1.0f;
    const Status s = plant.configure(bad);
    EXPECT_STREQ(s.group, "pi");
    EXPECT_STREQ(s.field, "thresholds");
    EXPECT_EQ(plant.config().sections, 1);
    EXPECT_EQ(plant.config().pi.count, 4);
}

TEST(Plant, OutputMapBendsTheHysteresisOutput) {
    // Kuhnen's modified PI, y = S(PI[v]): the reference is the PI model by
    // its direct formula in double, then S(x) = x + sum_i q_i max(x - d_i, 0)
    // evaluated on it, no dynamics. Float against double: the PI output
    // (~10 µm) carries rounding of a few 2^-24 relative, S's slope is at
    // most 1: 1e-5 µm covers it.
    PlantConfig c = pi_stage();
    c.sections = 0;
    c.output_map.count = 2;
    c.output_map.thresholds_um = {1.0f, 3.0f};
    c.output_map.weights = {-0.3f, -0.4f};  // slopes 1, 0.7, 0.3: the loop saturates at the top
    HammersteinPlant plant;
    ASSERT_TRUE(plant.configure(c).ok());
    double w[4] = {0, 0, 0, 0}, worst = 0, top = -1e9, bottom = 1e9;
    for (int k = 0; k < 4000; ++k) {
        const float v = static_cast<float>(5.0 * std::sin(2.0 * M_PI * k / 2000.0));
        double x = c.pi.p0 * static_cast<double>(v);
        for (int j = 0; j < c.pi.count; ++j) {
            const double r = c.pi.thresholds[static_cast<unsigned>(j)];
            w[j] = std::max(v - r, std::min(v + r, w[j]));
            x += c.pi.weights[static_cast<unsigned>(j)] * w[j];
        }
        const double y = x - 0.3 * std::max(x - 1.0, 0.0) - 0.4 * std::max(x - 3.0, 0.0);
        const float got = plant.step(v);
        worst = std::max(worst, std::fabs(got - y));
        EXPECT_EQ(plant.static_displacement_um(), got);
        top = std::max(top, y);
        bottom = std::min(bottom, y);
    }
    EXPECT_LT(worst, 1e-5);
    // The map makes the loop asymmetric: compressed above 1 µm only.
    EXPECT_LT(top, -bottom * 0.7);  // S(4.24) = 2.77 against -4.24

    PlantConfig bad = c;
    bad.output_map.weights[1] = -0.8f;  // slope 1 - 0.3 - 0.8 < 0
    const Status s = plant.configure(bad);
    EXPECT_STREQ(s.field, "output_map.weights");
    EXPECT_EQ(s.index, 1);
    bad = c;
    bad.output_map.thresholds_um[1] = 0.5f;
    EXPECT_STREQ(plant.configure(bad).field, "output_map.thresholds_um");
    bad = c;
    bad.output_map.count = 9;
    EXPECT_STREQ(plant.configure(bad).field, "output_map.count");
    EXPECT_EQ(plant.config().output_map.weights[1], -0.4f);  // the accepted map kept
}
