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
