// The simulated signal chain: converters, amplifier, sensor, noise.
#include <gtest/gtest.h>

#include <cmath>
#include <limits>
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

namespace {

// A chain with every part on: DAC, amplifier lag and clamps, PI stage with a
// resonance, sensor lag and noise, ADC.
StageConfig full_chain() {
    StageConfig c;
    c.rate_Hz = 20000.0f;
    c.dac = {16, -1.0f, 11.0f};
    c.amplifier = {10.0f, -1.0f, 11.0f, 0.0f, 110.0f, 3000.0f};
    c.plant = reference::plant();
    c.sensor = {0.4f, 5000.0f, 0.002f, 3};
    c.adc = {16, 0.0f, 10.0f};
    return c;
}

float command(int k) { return static_cast<float>(5.0 + 4.5 * std::sin(k * 0.0021) + 0.3 * std::sin(k * 0.31)); }

}  // namespace

TEST(StageModel, WithoutTheRealStageEffectsTheChainIsThePartsInOrder) {
    // Reference: the signal chain written out from its parts, as it was
    // before offset, gain error, mains, creep and drift existed. The stage
    // with those fields at their defaults gives the same bits.
    const StageConfig c = full_chain();
    StageModel stage;
    ASSERT_TRUE(stage.configure(c).ok());
    Converter dac, adc;
    FirstOrderLag amp, sens;
    HammersteinPlant plant;
    SeededNoise noise;
    ASSERT_TRUE(dac.configure(c.dac).ok() && adc.configure(c.adc).ok());
    ASSERT_TRUE(amp.configure(c.amplifier.bandwidth_Hz, c.rate_Hz).ok());
    ASSERT_TRUE(sens.configure(c.sensor.bandwidth_Hz, c.rate_Hz).ok());
    ASSERT_TRUE(plant.configure(c.plant).ok());
    amp.reset();
    sens.reset();
    noise.seed(c.sensor.seed);
    for (int k = 0; k < 20000; ++k) {
        const float u = command(k);
        float v = dac.apply(u);
        v = v < -1.0f ? -1.0f : (v > 11.0f ? 11.0f : v);
        v = amp.apply(10.0f * v);
        v = v < 0.0f ? 0.0f : (v > 110.0f ? 110.0f : v);
        const float x = plant.step(v);
        float s = sens.apply(0.4f * x);
        s = s + 0.002f * noise.next_unit();
        ASSERT_EQ(stage.step(u), adc.apply(s)) << k;
    }
}

TEST(StageModel, OffsetAndGainErrorReadThroughTheActualGain) {
    // Ideal converters, no lags: reading = 0.4 (1 + 0.01) (x + 0.3).
    StageConfig c;
    c.rate_Hz = 20000.0f;
    c.plant.linear_gain_um_per_V = 1.5f;
    c.sensor = {0.4f, 0.0f, 0.0f, 1};
    c.sensor.offset_um = 0.3f;
    c.sensor.gain_error = 0.01f;
    StageModel stage;
    ASSERT_TRUE(stage.configure(c).ok());
    for (int k = 0; k < 2000; ++k) {
        const float u = command(k);
        const float y = stage.step(u);
        const double x = stage.displacement_um();
        EXPECT_EQ(stage.displacement_um(), 1.5f * u);  // the true position has neither
        const double expect = 0.4 * 1.01 * (x + 0.3);
        // Float: G = 0.4f * 1.01f (two roundings), G x and G 0.3 and their
        // sum (three more), the inputs' own rounding (0.4f, 0.3f, 0.01f: 3e-8
        // relative): 8 half-ulps of a reading up to 6.3 is 3e-6.
        EXPECT_NEAR(y, expect, 3e-6) << k;
    }
}

TEST(StageModel, MainsPickupIsOnTheReadingOnly) {
    StageConfig c;
    c.rate_Hz = 20000.0f;
    c.plant.linear_gain_um_per_V = 1.5f;
    c.sensor = {0.4f, 0.0f, 0.0f, 1};
    c.sensor.gain_error = 0.02f;
    c.sensor.mains.frequency_Hz = 50.0f;
    c.sensor.mains.count = 2;
    c.sensor.mains.amplitudes_um = {0.004f, 0.001f};
    StageModel stage;
    ASSERT_TRUE(stage.configure(c).ok());
    const double g = 0.4 * 1.02;
    double worst = 0.0;
    for (int n = 0; n < 20000; ++n) {
        const float y = stage.step(5.0f);
        ASSERT_EQ(stage.displacement_um(), 7.5f);
        const double t = n / 20000.0;
        const double mains = 0.004 * std::sin(2.0 * M_PI * 50.0 * t) + 0.001 * std::sin(2.0 * M_PI * 100.0 * t);
        worst = std::max(worst, std::fabs(y - g * (7.5 + mains)));
    }
    // Sine table and phase increment (test_mains_pickup.cpp: < 1e-10 µm
    // here), then the reading's float rounding: a few ulp of 3.06 (2.4e-7).
    EXPECT_LT(worst, 1e-6);
}

TEST(StageModel, DriftIsARampOfTheTruePosition) {
    StageConfig c;
    c.rate_Hz = 20000.0f;
    c.plant.linear_gain_um_per_V = 1.5f;
    c.plant.drift_um_per_s = 0.05f;
    StageModel stage;
    ASSERT_TRUE(stage.configure(c).ok());
    const uint32_t n_total = 1u << 21;  // 105 s
    for (uint32_t n = 0; n < n_total; ++n) {
        const float y = stage.step(2.0f);
        if (n % 4099 != 0 && n != n_total - 1) continue;
        // 3 µm + 0.05 µm/s * n / 20 kHz: drift per sample and n are exact
        // to float rounding (n < 2^24), so one rounding of the per-sample
        // drift (relative 6e-8 of up to 5.2 µm) and of each product and
        // sum: < 1e-6 µm.
        const double expect = 3.0 + 0.05 * n / 20000.0;
        ASSERT_NEAR(y, expect, 1e-6) << n;
    }
    stage.reset();
    EXPECT_EQ(stage.step(2.0f), 3.0f);  // t = 0 again
}

TEST(StageModel, CreepFollowsTheHysteresisOutput) {
    // The plant's creep is the creep bank on the hysteresis output: with no
    // dynamics the displacement is h + the bank's creep, bit for bit.
    StageConfig c;
    c.rate_Hz = 10000.0f;
    c.plant.linear_gain_um_per_V = 1.5f;
    c.plant.creep = {2.5f, 0.01f, 10.0f};
    StageModel stage;
    ASSERT_TRUE(stage.configure(c).ok());
    CreepBank bank;
    ASSERT_TRUE(bank.configure(c.plant.creep, c.rate_Hz).ok());
    for (int k = 0; k < 50000; ++k) {
        const float u = command(k);
        ASSERT_EQ(stage.step(u), bank.apply(1.5f * u)) << k;
    }
}

TEST(StageModel, RealStageEffectsRefuseBadValuesByName) {
    struct Bad {
        void (*edit)(StageConfig&);
        const char* group;
        const char* field;
        int index;
    };
    const Bad bad[] = {
        {[](StageConfig& c) { c.sensor.offset_um = std::numeric_limits<float>::quiet_NaN(); }, "sensor", "offset_um", -1},
        {[](StageConfig& c) { c.sensor.offset_um = 2000.0f; }, "sensor", "offset_um", -1},
        {[](StageConfig& c) { c.sensor.gain_error = 0.9f; }, "sensor", "gain_error", -1},
        {[](StageConfig& c) { c.sensor.mains.count = 2; c.sensor.mains.amplitudes_um[1] = -1.0f; }, "sensor",
         "mains.amplitudes_um", 1},
        {[](StageConfig& c) { c.sensor.mains.count = 9; }, "sensor", "mains.count", -1},
        {[](StageConfig& c) { c.sensor.mains.count = 1; c.sensor.mains.frequency_Hz = 20000.0f; }, "sensor",
         "mains.frequency_Hz", -1},
        {[](StageConfig& c) { c.plant.creep = {2.0f, 0.01f, 30.0f}; }, "plant", "creep.to_s", -1},
        {[](StageConfig& c) { c.plant.creep = {-2.0f, 0.01f, 10.0f}; }, "plant", "creep.percent_per_decade", -1},
        {[](StageConfig& c) { c.plant.creep = {2.0f, 1e-5f, 10.0f}; }, "plant", "creep.from_s", -1},
        {[](StageConfig& c) { c.plant.drift_um_per_s = 50.0f; }, "plant", "drift_um_per_s", -1},
    };
    for (const Bad& b : bad) {
        StageConfig c = full_chain();
        b.edit(c);
        StageModel stage;
        const Status s = stage.configure(c);
        ASSERT_FALSE(s.ok()) << b.field;
        EXPECT_STREQ(s.group, b.group) << b.field;
        EXPECT_STREQ(s.field, b.field);
        EXPECT_EQ(s.index, b.index) << b.field;
    }
    // The plant alone has no rate: creep or drift without one is refused.
    PlantConfig p{};
    p.drift_um_per_s = 0.1f;
    HammersteinPlant plant;
    EXPECT_STREQ(plant.configure(p).field, "drift_um_per_s");
    p.drift_um_per_s = 0.0f;
    p.creep = {2.0f, 0.01f, 10.0f};
    EXPECT_STREQ(plant.configure(p).field, "creep");
    EXPECT_TRUE(plant.configure(p, 10000.0f).ok());
}
