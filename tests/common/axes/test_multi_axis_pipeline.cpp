// The multi-axis pipeline: identity matrices compute exactly what Pipelines
// on their own compute; the channels stay within their hard limits and slew
// whatever the matrices and readings; refused matrices change nothing; a
// coupled stage is decoupled by its matrices.
#include <gtest/gtest.h>

#include <array>
#include <cmath>
#include <cstdint>
#include <cstring>
#include <limits>
#include <memory>
#include <random>

#include "piezoloop/axes/multi_axis_pipeline.hpp"
#include "piezoloop/loop_stepper.hpp"
#include "piezoloop/plant.hpp"
#include "piezoloop/reference_run.hpp"
#include "piezoloop/reference_stage.hpp"
#include "axes_property.hpp"

using namespace piezoloop;
using namespace piezoloop::test;

namespace {

template <class T>
using Single = Pipeline<T, 1024, 4, 1024>;
template <class T, int N>
using Multi = MultiAxisPipeline<T, N, 1024, 4, 1024>;

template <int N>
MultiAxisSetup<N> reference_setup() {
    MultiAxisSetup<N> s{};
    for (int i = 0; i < N; ++i) {
        s.axes[i] = reference::setup();
        s.channels[i] = reference::setup().hard;
    }
    return s;
}

template <class T>
bool same_bits(const TickSignals<T>& a, const TickSignals<T>& b) {
    return std::memcmp(&a, &b, sizeof a) == 0;
}
template <class T>
bool same_bits(T a, T b) {
    return std::memcmp(&a, &b, sizeof a) == 0;
}

TrajectoryConfig triangle(float amplitude_um, float frequency_Hz, float offset_um = 0.0f) {
    TrajectoryConfig t{};
    t.offset_um = offset_um;
    t.waveform = Waveform::kTriangle;
    t.amplitude_um = amplitude_um;
    t.frequency_Hz = frequency_Hz;
    t.sample_rate_Hz = reference::kRate_Hz;
    return t;
}

HammersteinPlant reference_plant() {
    HammersteinPlant p;
    EXPECT_TRUE(p.configure(reference::plant()).ok());
    return p;
}

// A one-axis MultiAxisPipeline as the reference run sees a Pipeline.
template <class T>
struct OneAxis {
    Multi<T, 1>& m;
    Status stage(const PipelineParams& p) { return m.axis(0).stage(p); }
    void arm() { m.arm_all(); }
    Status start_wave(const TrajectoryConfig& c) { return m.axis(0).start_wave(c); }
    const TickSignals<T>& last() const { return m.axis(0).last(); }
    T tick(T y) { return m.tick({y})[0]; }
};

template <class T>
class MultiAxisTyped : public ::testing::Test {};
using SampleTypes = ::testing::Types<float, Q31>;
TYPED_TEST_SUITE(MultiAxisTyped, SampleTypes);

}  // namespace

TYPED_TEST(MultiAxisTyped, OneAxisIsThePipelineBitForBit) {
    using T = TypeParam;
    // The reference run (the log hash every board prints) on both.
    auto single = std::make_unique<Single<T>>(reference::setup());
    auto multi = std::make_unique<Multi<T, 1>>(reference_setup<1>());
    ASSERT_TRUE(multi->setup_status().ok());
    HammersteinPlant p1, p2;
    const reference::RunResult a = reference::run_closed_loop<T>(*single, p1, reference::kHashTicks);
    OneAxis<T> one{*multi};
    const reference::RunResult b = reference::run_closed_loop<T>(one, p2, reference::kHashTicks);
    ASSERT_EQ(a.ticks, reference::kHashTicks);
    EXPECT_EQ(a.log_hash, b.log_hash);
    EXPECT_FALSE(multi->channels().active());

    // Every block (RC in the loop), the board's split phases on the
    // multi-axis side, every signal of every tick compared.
    auto s2 = std::make_unique<Single<T>>(reference::setup());
    auto m2 = std::make_unique<Multi<T, 1>>(reference_setup<1>());
    HammersteinPlant q1 = reference_plant(), q2 = reference_plant();
    ASSERT_TRUE(s2->stage(reference::all_blocks_params()).ok());
    ASSERT_TRUE(m2->axis(0).stage(reference::all_blocks_params()).ok());
    ASSERT_TRUE(m2->set_input_matrix(InputMatrix<1>{}).ok());  // explicit identity: still bypassed
    ASSERT_TRUE(m2->set_output_matrix(AxisMatrix<1>::identity()).ok());
    const SignalScale pos = reference::setup().position, volt = reference::setup().voltage;
    LoopStepper<T> l1(pos, volt, 1.0f), l2(pos, volt, 1.0f);
    int mismatches = 0;
    for (int k = 0; k < 20000; ++k) {
        if (k == 100) {
            s2->arm();
            m2->arm_all();
            ASSERT_TRUE(s2->start_wave(triangle(15.0f, 10.0f)).ok());
            ASSERT_TRUE(m2->axis(0).start_wave(triangle(15.0f, 10.0f)).ok());
        }
        const T u1 = l1.tick(*s2);
        m2->begin_tick();
        const T u2 = m2->output({l2.reading()})[0];
        m2->end_tick();
        l2.command(u2);
        if (!same_bits(u1, u2) || !same_bits(s2->last(), m2->axis(0).last())) ++mismatches;
        l1.step(q1);
        l2.step(q2);
    }
    EXPECT_EQ(mismatches, 0);
    EXPECT_GT(std::fabs(pos.to_physical(s2->last().r)), 0.1f);  // the wave ran
    EXPECT_EQ(m2->channel_clamped_samples(0), 0u);
}

TYPED_TEST(MultiAxisTyped, ThreeAxesAreThreePipelinesBitForBit) {
    using T = TypeParam;
    auto multi = std::make_unique<Multi<T, 3>>(reference_setup<3>());
    std::array<std::unique_ptr<Single<T>>, 3> single;
    std::array<HammersteinPlant, 3> ps, pm;
    const SignalScale pos = reference::setup().position, volt = reference::setup().voltage;
    std::array<LoopStepper<T>, 3> ls, lm;
    const std::array<PipelineParams, 3> params{reference::params(true, true), reference::params(false, true),
                                               reference::all_blocks_params()};
    const std::array<TrajectoryConfig, 3> waves{triangle(15.0f, 10.0f), triangle(8.0f, 25.0f),
                                                triangle(12.0f, 5.0f, -3.0f)};
    for (int i = 0; i < 3; ++i) {
        single[i] = std::make_unique<Single<T>>(reference::setup());
        ps[i] = reference_plant();
        pm[i] = reference_plant();
        ls[i] = LoopStepper<T>(pos, volt, 1.0f);
        lm[i] = LoopStepper<T>(pos, volt, 1.0f);
        ASSERT_TRUE(single[i]->stage(params[i]).ok());
        ASSERT_TRUE(multi->axis(i).stage(params[i]).ok());
        single[i]->arm();
        const Status st = single[i]->start_wave(waves[i]);
        ASSERT_TRUE(st.ok()) << st.field << ": " << st.message;
    }
    multi->arm_all();
    for (int i = 0; i < 3; ++i) ASSERT_TRUE(multi->axis(i).start_wave(waves[i]).ok());
    int mismatches = 0;
    for (int k = 0; k < 10000; ++k) {
        const std::array<T, 3> u = multi->tick({lm[0].reading(), lm[1].reading(), lm[2].reading()});
        for (int i = 0; i < 3; ++i) {
            const T ui = ls[i].tick(*single[i]);
            lm[i].command(u[i]);
            if (!same_bits(ui, u[i]) || !same_bits(single[i]->last(), multi->axis(i).last())) ++mismatches;
            ls[i].step(ps[i]);
            lm[i].step(pm[i]);
        }
    }
    EXPECT_EQ(mismatches, 0);
}

namespace {

// A pipeline whose axes slam their (wide) limits on extreme readings, with
// random valid matrices set between armed runs.
template <class T, int N>
void pipeline_property(uint64_t seed) {
    std::mt19937_64 rng(seed);
    std::uniform_real_distribution<float> lo(-60.0f, -1.0f), hi(1.0f, 60.0f), slew(1.0e4f, 1.0e6f),
        offset(-1000.0f, 1000.0f);
    MultiAxisSetup<N> s{};
    ChannelBounds<T, N> b;
    b.rate_Hz = 100000.0;
    PipelineParams p{};
    p.feedback = FeedbackKind::kSos;
    p.sos_count = 1;
    p.sos[0] = SosSection{50.0, 0.0, 0.0, 0.0, 0.0};  // 50 V/µm, static
    p.limits = LimitsConfig{-100.0f, 100.0f, 1.0e8f, 0.0f};
    for (int i = 0; i < N; ++i) {
        s.axes[i] = PipelineSetup{HardLimits{-100.0f, 100.0f, 1.0e8f}, 100000.0f, SignalScale{50.0f},
                                  SignalScale{150.0f}};
        s.channels[i] = b.hard[i] = HardLimits{lo(rng), hi(rng), slew(rng)};
        b.scale[i] = SignalScale{150.0f};
        b.prev[i] = std::clamp(0.0, static_cast<double>(b.hard[i].u_min_V), static_cast<double>(b.hard[i].u_max_V));
    }
    auto pipe = std::make_unique<Multi<T, N>>(s);
    ASSERT_TRUE(pipe->setup_status().ok());
    for (int i = 0; i < N; ++i) ASSERT_TRUE(pipe->axis(i).stage(p).ok());
    auto reading = [&] {
        std::array<T, N> y{};
        for (int i = 0; i < N; ++i) {
            if constexpr (std::is_same_v<T, float>) {
                const float extremes[] = {1.0e30f, -1.0e30f, 3.0e38f, -3.0e38f, 1.0e-40f};
                const bool extreme = std::bernoulli_distribution(0.2)(rng);
                y[i] = extreme ? extremes[rng() % 5] : std::uniform_real_distribution<float>(-60.0f, 60.0f)(rng);
            } else {
                y[i] = random_command<T>(rng);
            }
        }
        return y;
    };
    for (int m = 0; m < 2000; ++m) {
        pipe->disarm_all();
        b.check(pipe->tick(reading()));
        InputMatrix<N> in{random_valid_matrix<N>(rng), {}};
        for (int i = 0; i < N; ++i) in.offset_um[i] = offset(rng);
        ASSERT_TRUE(pipe->set_input_matrix(in).ok());
        ASSERT_TRUE(pipe->set_output_matrix(m % 5 == 0 ? AxisMatrix<N>::identity() : random_valid_matrix<N>(rng)).ok());
        for (int i = 0; i < N; ++i) (void)pipe->axis(i).limiter().clear_trip();
        pipe->arm_all();
        for (int k = 0; k < 10; ++k) b.check(pipe->tick(reading()));
    }
    EXPECT_EQ(b.violations, 0);
    for (int i = 0; i < N; ++i) {
        EXPECT_GT(pipe->channel_clamped_samples(i), 0u);
        EXPECT_GT(pipe->channel_slew_limited_samples(i), 0u);
    }
}

}  // namespace

TYPED_TEST(MultiAxisTyped, ChannelsStayWithinHardLimitsAndSlew) {
    using T = TypeParam;
    pipeline_property<T, 2>(13);
    pipeline_property<T, 3>(14);
}

namespace {

// Two reference axes, armed, on their triangles.
struct Twin {
    std::unique_ptr<Multi<float, 2>> pipe = std::make_unique<Multi<float, 2>>(reference_setup<2>());
    std::array<HammersteinPlant, 2> plant{reference_plant(), reference_plant()};
    std::array<LoopStepper<float>, 2> loop{
        LoopStepper<float>(reference::setup().position, reference::setup().voltage, 1.0f),
        LoopStepper<float>(reference::setup().position, reference::setup().voltage, 1.0f)};
    Twin() {
        for (int i = 0; i < 2; ++i) EXPECT_TRUE(pipe->axis(i).stage(reference::params()).ok());
        pipe->arm_all();
        EXPECT_TRUE(pipe->axis(0).start_wave(triangle(15.0f, 10.0f)).ok());
        EXPECT_TRUE(pipe->axis(1).start_wave(triangle(10.0f, 20.0f)).ok());
    }
    std::array<float, 2> tick() {
        const std::array<float, 2> u = pipe->tick({loop[0].reading(), loop[1].reading()});
        for (int i = 0; i < 2; ++i) {
            loop[i].command(u[i]);
            loop[i].step(plant[i]);
        }
        return u;
    }
};

int run_both(Twin& a, Twin& b, int ticks) {
    int mismatches = 0;
    for (int k = 0; k < ticks; ++k) {
        const auto ua = a.tick(), ub = b.tick();
        if (std::memcmp(&ua, &ub, sizeof ua) != 0 || !same_bits(a.pipe->axis(0).last(), b.pipe->axis(0).last()) ||
            !same_bits(a.pipe->axis(1).last(), b.pipe->axis(1).last()))
            ++mismatches;
    }
    return mismatches;
}

void expect_refused(const Status& s, const char* field, const char* message = nullptr) {
    EXPECT_STREQ(s.group, "axes");
    EXPECT_STREQ(s.field, field);
    if (message) {
        EXPECT_STREQ(s.message, message);
    }
}

}  // namespace

TEST(MultiAxis, RefusedMatricesChangeNothing) {
    Twin a, b;
    ASSERT_EQ(run_both(a, b, 2000), 0);
    AxisMatrix<2> decouple = AxisMatrix<2>::identity();
    decouple.m[0][1] = 0.2f;
    InputMatrix<2> tilt{};
    tilt.gain.m[1][0] = -0.1f;
    tilt.offset_um[0] = 1.0f;
    // Valid, but the axes are armed (one armed axis is enough).
    expect_refused(a.pipe->set_output_matrix(decouple), "output_matrix", "changes only while every axis is disarmed");
    expect_refused(a.pipe->set_input_matrix(tilt), "input_matrix", "changes only while every axis is disarmed");
    a.pipe->axis(0).disarm();
    b.pipe->axis(0).disarm();
    expect_refused(a.pipe->set_output_matrix(decouple), "output_matrix");
    EXPECT_FALSE(a.pipe->matrix_pending());
    EXPECT_EQ(a.pipe->output_matrix(), AxisMatrix<2>::identity());
    EXPECT_EQ(run_both(a, b, 2000), 0);

    // Disarmed, and invalid: NaN, Inf, out of bound, singular, condition 1e4.
    a.pipe->disarm_all();
    b.pipe->disarm_all();
    ASSERT_EQ(run_both(a, b, 10), 0);
    AxisMatrix<2> bad = decouple;
    bad.m[1][0] = std::numeric_limits<float>::quiet_NaN();
    expect_refused(a.pipe->set_output_matrix(bad), "output_matrix[1][0]");
    bad.m[1][0] = std::numeric_limits<float>::infinity();
    expect_refused(a.pipe->set_output_matrix(bad), "output_matrix[1][0]");
    bad.m[1][0] = -17.0f;
    expect_refused(a.pipe->set_output_matrix(bad), "output_matrix[1][0]", "must be finite and within +-16");
    bad = AxisMatrix<2>{};
    bad.m[0][0] = bad.m[0][1] = bad.m[1][0] = bad.m[1][1] = 2.0f;
    expect_refused(a.pipe->set_output_matrix(bad), "output_matrix",
                   "singular or ill-conditioned (1-norm condition number above 1000)");
    InputMatrix<2> bad_in{};
    bad_in.gain.m[1][1] = 1.0e-4f;
    expect_refused(a.pipe->set_input_matrix(bad_in), "input_matrix",
                   "singular or ill-conditioned (1-norm condition number above 1000)");
    bad_in = InputMatrix<2>{};
    bad_in.offset_um[1] = std::numeric_limits<float>::infinity();
    expect_refused(a.pipe->set_input_matrix(bad_in), "input_offset_um[1]");
    EXPECT_FALSE(a.pipe->matrix_pending());
    EXPECT_EQ(run_both(a, b, 500), 0);

    // Accepted while disarmed; a second request waits for the tick to take
    // the first over.
    ASSERT_TRUE(a.pipe->set_output_matrix(decouple).ok());
    expect_refused(a.pipe->set_output_matrix(AxisMatrix<2>::identity()), "output_matrix",
                   "the previous matrix is not yet taken over; retry after one tick");
    (void)a.tick();
    EXPECT_FALSE(a.pipe->matrix_pending());
    EXPECT_TRUE(a.pipe->channels().active());
    EXPECT_TRUE(a.pipe->set_output_matrix(AxisMatrix<2>::identity()).ok());
}

TEST(MultiAxis, SetupRefusals) {
    MultiAxisSetup<3> s = reference_setup<3>();
    s.axes[2].rate_Hz = 50000.0f;
    Multi<float, 3> rates(s);
    EXPECT_STREQ(rates.setup_status().group, "axes");
    EXPECT_STREQ(rates.setup_status().field, "rate_Hz");
    EXPECT_EQ(rates.setup_status().index, 2);
    EXPECT_TRUE(rates.channels().active());  // never skipped: its outputs are zero
    EXPECT_EQ(rates.tick({1.0f, 2.0f, 3.0f}), (std::array<float, 3>{0.0f, 0.0f, 0.0f}));

    s = reference_setup<3>();
    s.channels[1].u_max_V = std::numeric_limits<float>::quiet_NaN();
    Multi<float, 3> channel(s);
    EXPECT_STREQ(channel.setup_status().group, "channels");
    EXPECT_STREQ(channel.setup_status().field, "u_max_V");
    EXPECT_EQ(channel.setup_status().index, 1);
}

TYPED_TEST(MultiAxisTyped, MatricesDecoupleACoupledStage) {
    using T = TypeParam;
    // Two reference stages whose actuators are mixed (each piezo also pushes
    // the other axis: A) and read by tilted sensors with zero offsets
    // (reading = S x + d). The output matrix A^-1, the input matrix S^-1 and
    // the offsets -S^-1 d make the loops see two independent stages again:
    // the axes then track as the uncoupled pair does, up to the rounding of
    // the inverses. Without them, they do not.
    const double A[2][2] = {{1.0, 0.15}, {0.1, 1.0}};
    const double S[2][2] = {{1.0, 0.2}, {-0.1, 0.95}};
    const double d[2] = {5.0, -3.0};
    auto inverse = [](const double (&m)[2][2]) {
        const double det = m[0][0] * m[1][1] - m[0][1] * m[1][0];
        AxisMatrix<2> r{};
        r.m[0][0] = static_cast<float>(m[1][1] / det);
        r.m[0][1] = static_cast<float>(-m[0][1] / det);
        r.m[1][0] = static_cast<float>(-m[1][0] / det);
        r.m[1][1] = static_cast<float>(m[0][0] / det);
        return r;
    };
    const SignalScale pos = reference::setup().position, volt = reference::setup().voltage;
    auto run = [&](bool coupled, bool matrices) {
        auto pipe = std::make_unique<Multi<T, 2>>(reference_setup<2>());
        if (matrices) {
            const AxisMatrix<2> s_inv = inverse(S);
            InputMatrix<2> in{s_inv, {}};
            for (int i = 0; i < 2; ++i)
                in.offset_um[i] = static_cast<float>(-(s_inv.m[i][0] * d[0] + s_inv.m[i][1] * d[1]));
            EXPECT_TRUE(pipe->set_output_matrix(inverse(A)).ok());
            EXPECT_TRUE(pipe->set_input_matrix(in).ok());
        }
        std::array<HammersteinPlant, 2> plant{reference_plant(), reference_plant()};
        for (int i = 0; i < 2; ++i) EXPECT_TRUE(pipe->axis(i).stage(reference::params()).ok());
        pipe->arm_all();
        EXPECT_TRUE(pipe->axis(0).start_wave(triangle(15.0f, 10.0f)).ok());
        EXPECT_TRUE(pipe->axis(1).start_wave(triangle(10.0f, 20.0f)).ok());
        std::array<double, 2> x{};
        double e_max = 0.0;
        for (int k = 0; k < 30000; ++k) {
            std::array<T, 2> reading{};
            for (int i = 0; i < 2; ++i) {
                const double r = coupled ? S[i][0] * x[0] + S[i][1] * x[1] + d[i] : x[i];
                reading[i] = pos.to_sample<T>(static_cast<float>(r));
            }
            const std::array<T, 2> u = pipe->tick(reading);
            std::array<double, 2> u_V{volt.to_physical(u[0]), volt.to_physical(u[1])};
            for (int i = 0; i < 2; ++i) {
                const double drive = coupled ? A[i][0] * u_V[0] + A[i][1] * u_V[1] : u_V[i];
                x[i] = plant[i].step(static_cast<float>(drive));
            }
            if (k >= 10000)
                for (int i = 0; i < 2; ++i)
                    e_max = std::max(e_max, std::fabs(pos.to_physical(pipe->axis(i).last().r) - x[i]));
        }
        return e_max;
    };
    const double plain = run(false, false), decoupled = run(true, true), ignored = run(true, false);
    std::printf("e_max um: uncoupled %.4f  coupled + matrices %.4f  coupled, identity %.4f\n", plain, decoupled,
                ignored);
    EXPECT_NEAR(decoupled, plain, 0.01 * plain);
    EXPECT_GT(ignored, 3.0 * plain);
}
