// The simulated signal chain: converters, amplifier, sensor, noise.
#include <gtest/gtest.h>

#include <cmath>
#include <random>

#include "piezoloop/reference_stage.hpp"
#include "piezoloop/stage_model.hpp"

using namespace piezoloop;

TEST(Converter, QuantisesToHalfAnLsbAndClamps) {
    Converter c;
    ASSERT_TRUE(c.configure({16, -10.0f, 10.0f}).ok());
    const double lsb = 20.0 / 65535.0;
    EXPECT_NEAR(c.lsb(), lsb, 1e-9);
    std::mt19937 rng(1);
    std::uniform_real_distribution<float> d(-10.0f, 10.0f);
    for (int i = 0; i < 100000; ++i) {
        const float x = d(rng);
        // Round to nearest: half an LSB, plus float rounding of min + code*lsb
        // near 10 V (ulp 1e-6): 0.5 lsb + 2e-6.
        EXPECT_LE(std::fabs(c.apply(x) - x), 0.5 * lsb + 2e-6) << x;
    }
    EXPECT_FLOAT_EQ(c.apply(25.0f), 10.0f);
    EXPECT_FLOAT_EQ(c.apply(-25.0f), -10.0f);
    EXPECT_FLOAT_EQ(c.apply(NAN), -10.0f);
    Converter ideal;
    ASSERT_TRUE(ideal.configure({0, -1.0f, 1.0f}).ok());
    EXPECT_EQ(ideal.apply(0.123456f), 0.123456f);
    EXPECT_STREQ(ideal.configure({30, -1.0f, 1.0f}).field, "bits");
    EXPECT_STREQ(ideal.configure({16, 1.0f, -1.0f}).field, "max");
}

TEST(FirstOrderLag, StepResponseAndCornerMatchTheContinuousLag) {
    // 3 kHz lag at 100 kHz: the step response follows 1 - exp(-t/tau) to
    // within Tustin's error, a few 1e-3 at these ratios; DC gain exactly 1.
    FirstOrderLag lag;
    ASSERT_TRUE(lag.configure(3000.0f, 1e5f).ok());
    const double tau = 1.0 / (2.0 * M_PI * 3000.0);
    double worst = 0.0;
    float y = 0.0f;
    for (int k = 0; k < 2000; ++k) {
        y = lag.apply(1.0f);
        const double t = (k + 0.5) * 1e-5;  // Tustin's half-sample alignment
        worst = std::max(worst, std::fabs(y - (1.0 - std::exp(-t / tau))));
    }
    EXPECT_LT(worst, 5e-3);
    EXPECT_NEAR(y, 1.0f, 1e-6);
    EXPECT_STREQ(lag.configure(60000.0f, 1e5f).field, "bandwidth_Hz");
}

TEST(SeededNoise, UnitVarianceBoundedAndReproducible) {
    SeededNoise a, b;
    a.seed(42);
    b.seed(42);
    double sum = 0.0, sq = 0.0, peak = 0.0;
    const int n = 1000000;
    for (int i = 0; i < n; ++i) {
        const float x = a.next_unit();
        ASSERT_EQ(x, b.next_unit());
        sum += x;
        sq += double(x) * x;
        peak = std::max(peak, std::fabs(double(x)));
    }
    // Standard errors over 1e6 samples: mean 1e-3, variance ~1.4e-3; 5 sigma.
    EXPECT_NEAR(sum / n, 0.0, 5e-3);
    EXPECT_NEAR(sq / n, 1.0, 7e-3);
    EXPECT_LE(peak, 2.0 * std::sqrt(3.0) + 1e-6);  // Irwin-Hall bound
}

TEST(StageModel, IdealChainIsThePlant) {
    StageConfig c;
    c.plant = reference::plant();
    StageModel stage;
    ASSERT_TRUE(stage.configure(c).ok());
    HammersteinPlant plant;
    ASSERT_TRUE(plant.configure(reference::plant()).ok());
    for (int k = 0; k < 5000; ++k) {
        const float u = static_cast<float>(8.0 * std::sin(k * 0.003));
        ASSERT_EQ(stage.step(u), plant.step(u)) << k;
    }
}

TEST(StageModel, AmplifierSaturatesAndConvertersQuantise) {
    // Ahmad2020-like chain: amplifier input -2..12 V, gain 10, output
    // -30..130 V, 3 kHz; linear stage 0.3 µm/V; sensor 0.2857 V/µm, 16-bit
    // ADC over 0..10 V.
    StageConfig c;
    c.dac = {16, -2.0f, 12.0f};
    c.amplifier = {10.0f, -2.0f, 12.0f, -30.0f, 130.0f, 3000.0f};
    c.plant.linear_gain_um_per_V = 0.3f;
    c.sensor = {10.0f / 35.0f, 10000.0f, 0.0f, 1};
    c.adc = {16, 0.0f, 10.0f};
    StageModel stage;
    ASSERT_TRUE(stage.configure(c).ok());
    float y = 0.0f;
    for (int k = 0; k < 3000; ++k) y = stage.step(20.0f);  // far above the input range
    EXPECT_LE(stage.piezo_voltage_V(), 130.0f);
    EXPECT_NEAR(stage.piezo_voltage_V(), 120.0f, 1e-3);  // clamped to 12 V in, x10
    EXPECT_NEAR(stage.displacement_um(), 36.0f, 1e-3);
    // The ADC reads the sensor (36 µm * 0.2857 = 10.29 V) railed at 10 V.
    EXPECT_FLOAT_EQ(y, 10.0f);
    for (int k = 0; k < 3000; ++k) y = stage.step(5.0f);
    const double expect = 5.0 * 10.0 * 0.3 * (10.0 / 35.0);
    EXPECT_NEAR(y, expect, 10.0 / 65535.0);  // within an ADC LSB once settled
    StageConfig bad = c;
    bad.amplifier.output_max_V = -50.0f;
    const Status s = stage.configure(bad);
    EXPECT_STREQ(s.group, "amplifier");
    EXPECT_STREQ(s.field, "output_max_V");
}
