// The PI compensator's start state at arming (pi_start_state.hpp): its
// output at the first input is the command in effect, its states are ones a
// history can leave, and a pipeline armed on a stage at rest away from its
// model's origin does not step its command.
#include <gtest/gtest.h>

#include <array>
#include <cmath>
#include <memory>
#include <random>

#include "piezoloop/pi_inverse.hpp"
#include "piezoloop/pi_start_state.hpp"
#include "piezoloop/pipeline.hpp"
#include "piezoloop/reference_stage.hpp"
#include "play_sum_double.hpp"

using namespace piezoloop;

namespace {

// The reference (tests/support) takes the play domain's f: the input map is
// applied here in float, as the operator and the solver apply it, so the
// states' clamps agree.
struct DoublePlay : test::PlaySumDouble {
    double apply(float x) { return test::PlaySumDouble::apply(static_cast<double>(m.input_gain * x + m.input_offset)); }
};

PiModel random_model(std::mt19937& rng) {
    std::uniform_real_distribution<float> unit(0.0f, 1.0f);
    PiModel m;
    m.input_gain = 0.5f + unit(rng);
    m.input_offset = 0.4f * (unit(rng) - 0.5f);
    m.p0 = 0.3f + unit(rng);
    m.count = 1 + static_cast<int>(rng() % kMaxPlayOperators);
    float r = 0.0f;
    for (int j = 0; j < m.count; ++j) {
        r += 0.05f + unit(rng);
        m.thresholds[static_cast<unsigned>(j)] = r;
        m.weights[static_cast<unsigned>(j)] = 0.4f * (unit(rng) - 0.6f);  // mostly negative: an inverse's
    }
    return m;
}

}  // namespace

TEST(PiStartState, TheStartStatesGiveTheCommandInEffect) {
    // 200 seeded models, inputs and commands inside the loop the model spans
    // at that input: the command of a turn t' drawn at random on
    // [f, f + 2 r_max]. The solver's states, run through the float operator
    // and through the double reference, give that command. Tolerance 2e-5:
    // the float operator's sum of up to 17 terms (each < ~20) in float, each
    // rounding <= 1e-6, against double; the solver's interpolation is exact.
    std::mt19937 rng(25);
    std::uniform_real_distribution<double> unit(0.0, 1.0);
    for (int n = 0; n < 200; ++n) {
        SCOPED_TRACE(n);
        const PiModel m = random_model(rng);
        const float x = static_cast<float>(10.0 * (unit(rng) - 0.5));
        const double f = static_cast<double>(m.input_gain * x + m.input_offset);
        const double t_drawn = f + 2.0 * m.thresholds[static_cast<unsigned>(m.count - 1)] * unit(rng);
        DoublePlay drawn{{m}};
        drawn.ascended_to(t_drawn);
        const double u = drawn.apply(x);

        const PiStartState s = pi_start_for_output(m, x, u, 1e-9);
        DoublePlay fresh{{m}};
        if (std::abs(fresh.apply(x) - u) <= 1e-9) continue;  // zero states already give u
        ASSERT_TRUE(s.preset);
        DoublePlay ref{{m}};
        ref.ascended_to(s.turn);
        EXPECT_NEAR(ref.apply(x), u, 1e-9);
        // States a history can leave: within a threshold of the input.
        for (int j = 0; j < m.count; ++j)
            EXPECT_LE(std::abs(ref.w[static_cast<unsigned>(j)] - f), m.thresholds[static_cast<unsigned>(j)] + 1e-9);

        PiOperator<float> op;
        ASSERT_TRUE(op.configure(m).ok());
        op.start_ascended_to(static_cast<float>(s.turn));
        EXPECT_NEAR(op.apply(x), u, 2e-5);
    }
}

TEST(PiStartState, ZeroStatesStayWhereTheyAlreadyGiveTheCommand) {
    // A plain model at 0 outputs 0 from zero states: nothing to preset, so a
    // loop armed at rest at zero runs exactly the arithmetic it always has.
    PiModel m = reference::stage_model();
    EXPECT_FALSE(pi_start_for_output(m, 0.0f, 0.0, 1e-9).preset);
    // Within the tolerance, likewise; beyond it, a preset.
    DoublePlay fresh{{m}};
    const double u0 = fresh.apply(1.0f);
    EXPECT_FALSE(pi_start_for_output(m, 1.0f, u0 + 0.5e-3, 1e-3).preset);
    EXPECT_TRUE(pi_start_for_output(m, 1.0f, u0 + 2e-3, 1e-3).preset);
}

TEST(PiStartState, ACommandBeyondTheLoopTakesTheNearestBranch) {
    // Hardening weights only: G(t) falls monotonically from the ascending
    // major branch (t = f) to the descending one (t >= f + 2 r_max). A command
    // far above both takes the ascending branch, far below the descending.
    PiModel m;
    m.p0 = 1.0f;
    m.count = 3;
    m.thresholds = {0.5f, 1.0f, 2.0f};
    m.weights = {-0.2f, -0.1f, -0.05f};
    const float x = 1.0f;
    const PiStartState up = pi_start_for_output(m, x, 100.0, 1e-9);
    ASSERT_TRUE(up.preset);
    EXPECT_DOUBLE_EQ(up.turn, 1.0);  // f
    const PiStartState down = pi_start_for_output(m, x, -100.0, 1e-9);
    ASSERT_TRUE(down.preset);
    EXPECT_DOUBLE_EQ(down.turn, 1.0 + 2.0 * 2.0);  // f + 2 r_max
    // Analytic branches at x = 1: ascending w = x - r = (0.5, 0, -1),
    // descending w = x + r capped by the turn: (1.5, 2, 3). Tolerance 1e-7:
    // the weights are floats (0.2f = 0.2 + 3e-9).
    DoublePlay a{{m}}, d{{m}};
    a.ascended_to(up.turn);
    d.ascended_to(down.turn);
    EXPECT_NEAR(a.apply(x), 1.0 - 0.2 * 0.5 - 0.1 * 0.0 - 0.05 * -1.0, 1e-7);
    EXPECT_NEAR(d.apply(x), 1.0 - 0.2 * 1.5 - 0.1 * 2.0 - 0.05 * 3.0, 1e-7);
}

namespace {

// A stack's PI model (V -> µm): 2 µm/V and five play operators whose
// weights add slope as the voltage leaves its turning point, so that the
// stage keeps a remnant displacement after a run (as a real one does: about
// 2.3 µm after 0 -> 8 V -> 0 here).
PiModel stack_model() {
    PiModel m;
    m.p0 = 2.0f;
    m.count = 5;
    m.thresholds = {1.0f, 2.0f, 3.0f, 4.0f, 5.0f};
    m.weights = {0.3f, 0.25f, 0.2f, 0.15f, 0.1f};
    return m;
}

// The stage's reading after 0 V -> peak -> 0 V in small steps.
double remnant_um(float peak_V) {
    DoublePlay stage{{stack_model()}};
    const int n = 2000;
    double y = 0.0;
    for (int k = 0; k <= 2 * n; ++k) {
        const double v = peak_V * (k <= n ? k : 2 * n - k) / n;
        y = stage.apply(static_cast<float>(v));
    }
    return y;
}

template <class T>
void arming_on_a_remnant_does_not_step_the_command(float peak_V) {
    const PipelineSetup su = reference::setup();
    PipelineParams p = reference::params(true, false);  // the inverse alone: u = u_ff
    p.pi = stack_model();
    auto pipe = std::make_unique<Pipeline<T, 1024, 4, 1024>>(su);
    ASSERT_TRUE(pipe->stage(p).ok());
    const float y0 = static_cast<float>(remnant_um(peak_V));
    const T y = su.position.to_sample<T>(y0);
    for (int k = 0; k < 3; ++k) EXPECT_EQ(su.voltage.to_physical(pipe->tick(y)), 0.0f);  // disarmed: 0 V
    pipe->set_setpoint(y);
    pipe->arm();
    const float u = su.voltage.to_physical(pipe->tick(y));
    // Zero states would command the virgin curve's P^-1(y0): far from 0 V
    // (the check below could not pass by accident).
    PiModel inverse{};
    ASSERT_TRUE(invert_pi(p.pi, inverse).ok());
    DoublePlay virgin{{inverse}};
    const double jump_V = virgin.apply(y0);
    EXPECT_GT(std::abs(jump_V), 0.2) << "y0 " << y0;
    // Tolerance 1e-4 V: the float sum of 16 terms (< 0.1 ms of rounding at
    // ~10 V) or Q31's quantised weights, against an exact crossing.
    EXPECT_NEAR(u, 0.0f, 1e-4) << "y0 " << y0 << " µm; from zero states " << jump_V << " V";
    // From there the command follows the reference without a step: the
    // reference carries on down by 1 µm over 1000 ticks.
    float prev = u;
    for (int k = 1; k <= 1000; ++k) {
        const float r = y0 - peak_V / std::abs(peak_V) * 1.0f * static_cast<float>(k) / 1000.0f;
        pipe->set_setpoint(su.position.to_sample<T>(r));
        const float uk = su.voltage.to_physical(pipe->tick(su.position.to_sample<T>(r)));
        ASSERT_LT(std::abs(uk - prev), 0.01f) << "tick " << k;
        prev = uk;
    }
}

}  // namespace

TEST(PiStartState, ArmingOnARemnantDoesNotStepTheCommand) {
    for (const float peak_V : {8.0f, -8.0f, 3.0f}) {
        SCOPED_TRACE(peak_V);
        arming_on_a_remnant_does_not_step_the_command<float>(peak_V);
    }
}

TEST(PiStartState, Q31ArmingOnARemnantDoesNotStepTheCommand) {
    for (const float peak_V : {8.0f, -8.0f, 3.0f}) {
        SCOPED_TRACE(peak_V);
        arming_on_a_remnant_does_not_step_the_command<Q31>(peak_V);
    }
}
