// The stage of coupled axes (axes/coupled_stage.hpp): one axis without a path
// is StageModel bit for bit; two and three axes are their StageModels'
// actuate / sense with the paths' filters between them, in the documented
// order, bit for bit; a bad configuration names its field and changes
// nothing. Its linear response against scipy is tested on the host
// (tests/host/sim/test_coupled_stage_build.cpp, tests/golden/coupled_stage_ref.json).
#include <gtest/gtest.h>

#include <bit>
#include <cmath>
#include <cstdint>
#include <string>

#include "piezoloop/axes/coupled_stage.hpp"

using namespace piezoloop;

namespace {

// A stage with every part in use: a 12-bit DAC, an amplifier with gain,
// bandwidth and clamps, a PI hysteresis, creep, drift, a resonant biquad,
// a sensor with gain, gain error, bandwidth, offset, mains pickup and noise,
// and a 14-bit ADC. `seed` varies the noise between axes.
StageConfig full_stage(uint32_t seed, float rate_Hz = 20000.0f) {
    StageConfig c{};
    c.rate_Hz = rate_Hz;
    c.dac = ConverterConfig{12, 0.0f, 10.0f};
    c.amplifier = AmplifierConfig{15.0f, 0.0f, 10.0f, 0.0f, 150.0f, 3000.0f};
    c.plant.hysteresis = HysteresisKind::kPi;
    c.plant.pi.count = 3;
    c.plant.pi.thresholds = {0.0f, 20.0f, 60.0f};
    c.plant.pi.weights = {0.4f, 0.1f, 0.05f};
    c.plant.pi.p0 = 0.1f;
    c.plant.sections = 1;
    // A 900 Hz mode (zeta 0.03) at 20 kHz, unit DC gain.
    c.plant.dynamics[0] = SosSection{0.019196, 0.0, 0.0, -1.9371, 0.956296};
    c.plant.creep = CreepConfig{2.0f, 0.01f, 1.0f};
    c.plant.drift_um_per_s = 0.05f;
    c.sensor.gain = 0.1f;
    c.sensor.bandwidth_Hz = 5000.0f;
    c.sensor.noise_rms = 0.0003f;
    c.sensor.seed = seed;
    c.sensor.offset_um = 0.2f;
    c.sensor.gain_error = 0.01f;
    c.sensor.mains.frequency_Hz = 50.0f;
    c.sensor.mains.count = 2;
    c.sensor.mains.amplitudes_um[0] = 0.005f;
    c.sensor.mains.amplitudes_um[1] = 0.003f;
    c.adc = ConverterConfig{14, -1.0f, 11.0f};
    return c;
}

// A command that sweeps the range and reverses (hysteresis at work).
float command_V(int k, int axis) {
    const double t = k / 20000.0;
    return static_cast<float>(5.0 + 4.5 * std::sin(2.0 * M_PI * (37.0 + 11.0 * axis) * t + axis) *
                                        std::cos(2.0 * M_PI * 3.0 * t));
}

CouplingPath path(int from, int to, double dc) {
    // dc * (a 750 Hz, zeta 0.15 second-order lowpass), its ZOH sections
    // rounded: any stable section will do for the composition tests.
    CouplingPath p{};
    p.from = from;
    p.to = to;
    p.sections = 1;
    const double a1 = -1.8569, a2 = 0.9317;
    p.filter[0] = SosSection{dc * (1.0 + a1 + a2), 0.0, 0.0, a1, a2};
    return p;
}

uint32_t bits(float x) { return std::bit_cast<uint32_t>(x); }

}  // namespace

TEST(CoupledStage, OneAxisWithoutCouplingIsStageModelBitForBit) {
    StageModel reference;
    ASSERT_TRUE(reference.configure(full_stage(7)).ok());
    CoupledStageConfig c{};
    c.axes = 1;
    c.axis[0] = full_stage(7);
    CoupledStage stage;
    ASSERT_TRUE(stage.configure(c).ok());
    for (int run = 0; run < 2; ++run) {  // and again after reset()
        for (int k = 0; k < 40000; ++k) {
            const float u = command_V(k, 0);
            float y = 0.0f;
            stage.step(&u, &y);
            const float r = reference.step(u);
            ASSERT_EQ(bits(y), bits(r)) << "run " << run << " sample " << k;
            ASSERT_EQ(bits(stage.displacement_um(0)), bits(reference.displacement_um()));
            ASSERT_EQ(bits(stage.position_um(0)), bits(reference.displacement_um()));
        }
        stage.reset();
        reference.reset();
    }
}

// Three axes, paths 0->1, 1->0, 0->2, 1->2 (a Y axis whose position gets two
// paths): each sample is the axes' actuate(), the paths on the displacements
// in their order, then sense() of the positions.
TEST(CoupledStage, ThreeAxesAreTheirStagesWithThePathsBetweenBitForBit) {
    CoupledStageConfig c{};
    c.axes = 3;
    for (int i = 0; i < 3; ++i) c.axis[static_cast<size_t>(i)] = full_stage(static_cast<uint32_t>(i + 1));
    c.paths = 4;
    c.coupling = {path(0, 1, 0.03), path(1, 0, 0.025), path(0, 2, 0.01), path(1, 2, 0.012)};
    CoupledStage stage;
    ASSERT_TRUE(stage.configure(c).ok());
    std::array<StageModel, 3> axis;
    std::array<BiquadCascade<float, kMaxCouplingSections>, 4> filter;
    for (int i = 0; i < 3; ++i) ASSERT_TRUE(axis[static_cast<size_t>(i)].configure(c.axis[static_cast<size_t>(i)]).ok());
    for (int k = 0; k < 4; ++k)
        ASSERT_TRUE(filter[static_cast<size_t>(k)]
                        .configure(c.coupling[static_cast<size_t>(k)].filter.data(), 1, {}, {}, FormChoice::kCoefficients)
                        .ok());
    float moved = 0.0f;
    for (int k = 0; k < 20000; ++k) {
        const float u[3] = {command_V(k, 0), command_V(k, 1), command_V(k, 2)};
        float y[3];
        stage.step(u, y);
        const float x0 = axis[0].actuate(u[0]), x1 = axis[1].actuate(u[1]), x2 = axis[2].actuate(u[2]);
        const float c01 = filter[0].apply(x0), c10 = filter[1].apply(x1), c02 = filter[2].apply(x0), c12 = filter[3].apply(x1);
        const float p0 = x0 + c10, p1 = x1 + c01, p2 = (x2 + c02) + c12;
        ASSERT_EQ(bits(y[0]), bits(axis[0].sense(p0))) << k;
        ASSERT_EQ(bits(y[1]), bits(axis[1].sense(p1))) << k;
        ASSERT_EQ(bits(y[2]), bits(axis[2].sense(p2))) << k;
        ASSERT_EQ(bits(stage.displacement_um(1)), bits(x1));
        ASSERT_EQ(bits(stage.position_um(2)), bits(p2));
        moved = std::fmax(moved, std::fabs(p2 - x2));
    }
    EXPECT_GT(moved, 0.1f);  // the paths did move axis 2
}

TEST(CoupledStage, BadConfigurationsNameTheFieldAndChangeNothing) {
    CoupledStageConfig good{};
    good.axes = 2;
    good.axis[0] = full_stage(1);
    good.axis[1] = full_stage(2);
    good.paths = 1;
    good.coupling[0] = path(0, 1, 0.03);
    CoupledStage stage;
    ASSERT_TRUE(stage.configure(good).ok());
    const float u[2] = {3.0f, 4.0f};
    float y_ref[2];
    {
        CoupledStage fresh;
        ASSERT_TRUE(fresh.configure(good).ok());
        fresh.step(u, y_ref);
    }
    auto expect_refused = [&](CoupledStageConfig c, const char* group, const char* field) {
        const Status s = stage.configure(c);
        ASSERT_FALSE(s.ok());
        EXPECT_STREQ(s.group ? s.group : "", group);
        EXPECT_STREQ(s.field, field);
        // Still the good stage, at rest.
        EXPECT_EQ(stage.axes(), 2);
        float y[2];
        CoupledStage copy = stage;
        copy.step(u, y);
        EXPECT_EQ(bits(y[0]), bits(y_ref[0]));
        EXPECT_EQ(bits(y[1]), bits(y_ref[1]));
    };
    CoupledStageConfig c = good;
    c.axes = 0;
    expect_refused(c, "", "axes");
    c.axes = 4;
    expect_refused(c, "", "axes");
    c = good;
    c.paths = 7;
    expect_refused(c, "", "paths");
    c = good;
    c.coupling[0].to = 0;  // from an axis to itself
    expect_refused(c, "coupling[0]", "to");
    c = good;
    c.coupling[0].from = 2;  // no axis 2
    expect_refused(c, "coupling[0]", "from");
    c = good;
    c.coupling[0].to = -1;
    expect_refused(c, "coupling[0]", "to");
    c = good;
    c.paths = 2;
    c.coupling[1] = path(0, 1, 0.01);  // the same pair again
    expect_refused(c, "coupling[1]", "to");
    c = good;
    c.coupling[0].sections = 0;
    expect_refused(c, "coupling[0]", "sections");
    c = good;
    c.coupling[0].filter[0].a2 = 1.5;  // unstable
    expect_refused(c, "coupling[0].filter", "sections[0].a2");
    c = good;
    c.axis[1].rate_Hz = 10000.0f;
    expect_refused(c, "axis[1]", "rate_Hz");
    c = good;
    c.axis[1].sensor.gain = 0.0f;
    expect_refused(c, "axis[1].sensor", "gain");
    c = good;
    c.axis[0].plant.sections = 7;
    expect_refused(c, "axis[0].plant", "sections");
    c = good;
    c.axis[1].dac.bits = 1;
    expect_refused(c, "axis[1].dac", "bits");
}
