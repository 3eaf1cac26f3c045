// The closed-loop stepper (common/piezoloop/loop_stepper.hpp) on stand-ins
// whose every value is known by hand: a "controller" that returns its input
// plus a constant and a "stage" that returns a multiple of its input, so the
// sequence of readings is a closed-form recurrence. Checked: one sample of
// compute delay (y_0 = 0, the command of tick k read back at tick k + 1),
// the sensor gain, the physical <-> sample conversions (Q31 against
// Q31::from_float / to_float done here by hand), reset. Exact: the stand-ins
// use values that float represents exactly (halves, small integers), and
// the Q31 expectations are computed with the same conversions.
#include <gtest/gtest.h>

#include <vector>

#include "piezoloop/loop_stepper.hpp"
#include "piezoloop/q31.hpp"
#include "piezoloop/sample.hpp"

using namespace piezoloop;

namespace {

// u = y + offset, in the sample type; remembers what it was given.
template <class T>
struct AddController {
    T offset;
    std::vector<T> inputs;
    T tick(T y) {
        inputs.push_back(y);
        return y + offset;
    }
    T output(T y) { return tick(y); }
};

// reading = gain_um_per_V * u_V; remembers the voltages it was driven with.
struct ScaleStage {
    float gain_um_per_V;
    std::vector<float> inputs_V;
    float step(float u_V) {
        inputs_V.push_back(u_V);
        return gain_um_per_V * u_V;
    }
};

}  // namespace

TEST(LoopStepper, FloatOneSampleOfComputeDelayAndSensorGain) {
    // Sensor gain 2: the reading is 2 per µm, so y = reading / 2.
    LoopStepper<float> loop(SignalScale{50.0f}, SignalScale{10.0f}, 2.0f);
    AddController<float> ctrl{1.0f, {}};
    ScaleStage stage{3.0f, {}};  // reading = 3 u
    // By hand: y_0 = 0; u_k = y_k + 1; reading = 3 u_k; y_{k+1} = 1.5 u_k.
    float y = 0.0f;
    for (int k = 0; k < 5; ++k) {
        EXPECT_EQ(loop.reading(), y) << k;
        const float u = loop.tick(ctrl);
        EXPECT_EQ(u, y + 1.0f) << k;
        EXPECT_EQ(stage.inputs_V.size(), static_cast<std::size_t>(k));  // not applied before step()
        loop.step(stage);
        EXPECT_EQ(stage.inputs_V.back(), u) << k;  // float: volts are the sample itself
        y = 1.5f * u;
    }
    EXPECT_EQ(ctrl.inputs, (std::vector<float>{0.0f, 1.5f, 3.75f, 7.125f, 12.1875f}));
}

TEST(LoopStepper, CommandAndOutputPhaseAreAppliedByTheNextStep) {
    LoopStepper<float> loop(SignalScale{50.0f}, SignalScale{10.0f}, 1.0f);
    ScaleStage stage{1.0f, {}};
    loop.command(0.25f);
    EXPECT_EQ(loop.reading(), 0.0f);
    loop.step(stage);
    EXPECT_EQ(stage.inputs_V, std::vector<float>{0.25f});
    EXPECT_EQ(loop.reading(), 0.25f);
    AddController<float> ctrl{0.5f, {}};
    loop.output(ctrl);  // a board's output phase: same command as tick()
    loop.step(stage);
    EXPECT_EQ(stage.inputs_V.back(), 0.75f);
    EXPECT_EQ(loop.reading(), 0.75f);
    loop.reset();
    EXPECT_EQ(loop.reading(), 0.0f);
    loop.step(stage);
    EXPECT_EQ(stage.inputs_V.back(), 0.0f);  // reset: command 0 V
}

TEST(LoopStepper, Q31ConvertsThroughTheFullScales) {
    const SignalScale pos{50.0f}, volt{10.0f};
    LoopStepper<Q31> loop(pos, volt, 1.0f);
    AddController<Q31> ctrl{Q31::from_float(0.125f), {}};  // +1.25 V per tick
    ScaleStage stage{4.0f, {}};                             // 4 µm per V
    EXPECT_EQ(loop.reading(), Q31{});
    float y_um = 0.0f;
    for (int k = 0; k < 4; ++k) {
        const Q31 y = Q31::from_float(y_um / 50.0f);
        EXPECT_EQ(loop.reading(), y) << k;
        const Q31 u = loop.tick(ctrl);
        EXPECT_EQ(u, y + Q31::from_float(0.125f)) << k;
        loop.step(stage);
        const float u_V = u.to_float() * 10.0f;
        EXPECT_EQ(stage.inputs_V.back(), u_V) << k;
        y_um = 4.0f * u_V;
    }
}
