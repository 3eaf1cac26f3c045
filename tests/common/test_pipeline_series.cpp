// Series placement of the hysteresis compensator (FeedforwardKind::kPiSeries,
// Shan2012): u = limits(P^-1(r + u_fb)), the feedback's output a displacement
// correction in µm. Checked against the blocks composed by hand and against a
// double evaluation of the play operators written here; the limits, the
// validation and the swap/arm behaviour of the placement.
#include <gtest/gtest.h>

#include <algorithm>
#include <array>
#include <cmath>
#include <memory>
#include <random>

#include "piezoloop/pipeline.hpp"
#include "play_sum_double.hpp"

using namespace piezoloop;

namespace {

template <class T>
using SeriesPipeline = Pipeline<T, 256, 4, 64>;

constexpr float kRate_Hz = 100000.0f;

// Shan2012's loop: -1..10 V on the amplifier input; full scales 16 µm and
// 12 V (unequal, so that a feedback scaled to the wrong one shows in Q31).
PipelineSetup setup(float hard_slew_V_per_s = 1e7f) {
    PipelineSetup s;
    s.hard = HardLimits{-1.0f, 10.0f, hard_slew_V_per_s};
    s.rate_Hz = kRate_Hz;
    s.position = SignalScale{16.0f};
    s.voltage = SignalScale{12.0f};
    return s;
}

// A compensator shaped like a PI inverse (µm -> V): steep at reversals,
// flattening with the thresholds (negative weights), with an affine input.
PiModel compensator() {
    PiModel m;
    m.input_gain = 1.1f;
    m.input_offset = 0.05f;
    m.p0 = 1.5f;
    m.count = 4;
    m.thresholds = {0.2f, 0.6f, 1.2f, 2.5f};
    m.weights = {-0.3f, -0.12f, -0.05f, -0.02f};
    return m;
}

PidConfig pid_um() {
    PidConfig c;
    c.kp = 0.5f;             // µm of command per µm of error
    c.ki_per_s = 2000.0f;
    c.kd_s = 0.0f;
    c.derivative_cutoff_Hz = 20000.0f;
    c.u_min = -5.0f;         // µm
    c.u_max = 5.0f;
    return c;
}

PipelineParams series_params(float slew_V_per_s = 1e7f) {
    PipelineParams p;
    p.feedforward = FeedforwardKind::kPiSeries;
    p.pi = compensator();
    p.feedback = FeedbackKind::kPid;
    p.pid = pid_um();
    p.limits = LimitsConfig{0.0f, 9.0f, slew_V_per_s, 0.0f};
    return p;
}

// Reference r: a 100 Hz triangle from 0 to 9.5 µm (the compensator then asks
// for up to ~12 V, so the 9 V limit binds near the top) plus a small seeded
// jitter; plant: a first-order lag with a slope of 0.75 µm/V.
struct Drive {
    std::mt19937 rng{2012};
    std::uniform_real_distribution<float> jitter{-0.02f, 0.02f};
    float y_um = 0.0f;
    float r_um(int k) {
        const int n = 1000, ph = k % n;
        const float tri = ph < n / 2 ? static_cast<float>(ph) / (n / 2) : static_cast<float>(n - ph) / (n / 2);
        return 9.5f * tri + jitter(rng);
    }
    void plant(float u_V) { y_um = 0.8f * y_um + 0.2f * 0.75f * u_V; }
};

template <class T>
T sample_of(SignalScale s, float x) { return s.to_sample<T>(x); }

// The pipeline against (a) the same blocks composed by hand: Pid (µm -> µm),
// PiOperator (µm -> V), OutputLimiter -- bit for bit, since the pipeline must
// run exactly these operations; (b) the clamp of a double evaluation of
// P^-1(r + u_fb), with the pipeline's own r and u_fb.
template <class T>
void check_series_equals_clamped_inverse(double tol_V) {
    const PipelineSetup su = setup();
    const PipelineParams p = series_params();
    auto pipe = std::make_unique<SeriesPipeline<T>>(su);
    ASSERT_TRUE(pipe->stage(p).ok());
    pipe->arm();

    Pid<T> pid;
    ASSERT_TRUE(pid.configure(p.pid, su.rate_Hz, su.position, su.position).ok());
    PiOperator<T> pi;
    ASSERT_TRUE(pi.configure(p.pi, su.position, su.voltage).ok());
    OutputLimiter<T> lim(su.hard, su.rate_Hz, su.voltage);
    ASSERT_TRUE(lim.configure(p.limits).ok());
    test::PlaySumDouble dpi{p.pi};
    // Arming is bumpless (pi_start_state.hpp): the compensator starts from
    // the states whose output at the held setpoint (0 µm) is the command in
    // effect (0 V), not from zero states (p0 x the input offset: 0.075 V).
    const PiStartState start = pi_start_for_output(p.pi, 0.0f, 0.0, 1e-4 * su.voltage.full_scale);
    ASSERT_TRUE(start.preset);
    pi.start_ascended_to(sample_of<T>(su.position, static_cast<float>(start.turn)));
    dpi.ascended_to(start.turn);

    Drive d;
    int clamped = 0, inside = 0;
    for (int k = 0; k < 5000; ++k) {
        const T r = sample_of<T>(su.position, d.r_um(k));
        const T y = sample_of<T>(su.position, d.y_um);
        pipe->set_setpoint(r);
        const T u = pipe->tick(y);
        const TickSignals<T>& s = pipe->last();

        // (a) composed by hand.
        const T u_fb = pid.apply(r - y);
        const T u_ff = pi.apply(r + u_fb);
        const T u_hand = lim.apply(u_ff);
        ASSERT_EQ(s.u_fb, u_fb) << "tick " << k;
        ASSERT_EQ(s.u_ff, u_ff) << "tick " << k;
        ASSERT_EQ(u, u_hand) << "tick " << k;

        // (b) clamp(P^-1(r + u_fb)) in double, slew not binding (1e7 V/s).
        const double x_um = static_cast<double>(su.position.to_physical(r)) +
                            static_cast<double>(su.position.to_physical(s.u_fb));
        const double v = dpi.apply(static_cast<double>(p.pi.input_gain) * x_um + static_cast<double>(p.pi.input_offset));
        const double expect = std::clamp(v, 0.0, 9.0);
        const double got = su.voltage.to_physical(u);
        ASSERT_NEAR(got, expect, tol_V) << "tick " << k;
        (v > 9.0 || v < 0.0 ? clamped : inside)++;
        d.plant(static_cast<float>(got));
    }
    // Both branches of the clamp were exercised.
    EXPECT_GT(clamped, 100);
    EXPECT_GT(inside, 1000);
}

}  // namespace

TEST(PipelineSeries, FloatOutputIsTheClampedInverseOfReferencePlusCorrection) {
    // Tolerance 2e-5 V: the float pipeline evaluates the affine input and the
    // sum of 5 products (|terms| <= ~15 V) in float, each rounding <= 0.5 ulp
    // (<= 1e-6 V), against the same sum in double; plus the limiter's
    // last + (target - last), one more rounding.
    check_series_equals_clamped_inverse<float>(2e-5);
}

TEST(PipelineSeries, Q31OutputIsTheClampedInverseOfReferencePlusCorrection) {
    // Tolerance 1e-6 V (~180 LSB of the 12 V full scale): Q31 thresholds and
    // input offset are rounded to 1 LSB of 16 µm (7.5e-9 µm), the weights to
    // a 31-bit mantissa under one block exponent, the input gain likewise,
    // and the output rounded once; |weights| sum to < 2.1 V/µm, so the error
    // is a few 1e-8 V. The limits are Q31 codes at or inside 0 / 9 V (< 1 LSB).
    check_series_equals_clamped_inverse<Q31>(1e-6);
}

TEST(PipelineSeries, SplitPhasesEqualTheWholeTick) {
    // A board runs begin_tick / output / end_tick apart; in series the
    // compensator moves to the output phase, the arithmetic must not change.
    auto a = std::make_unique<SeriesPipeline<float>>(setup());
    auto b = std::make_unique<SeriesPipeline<float>>(setup());
    for (auto* p : {a.get(), b.get()}) {
        ASSERT_TRUE(p->stage(series_params()).ok());
        p->arm();
    }
    Drive d;
    for (int k = 0; k < 3000; ++k) {
        const float r = d.r_um(k);
        a->set_setpoint(r);
        b->set_setpoint(r);
        const float ua = a->tick(d.y_um);
        b->begin_tick();
        const float ub = b->output(d.y_um);
        b->end_tick();
        ASSERT_EQ(ua, ub) << "tick " << k;
        ASSERT_EQ(a->last().u_ff, b->last().u_ff) << "tick " << k;
        d.plant(ua);
    }
}

TEST(PipelineSeries, HardLimitsHoldWhateverTheInput) {
    // Hostile readings and setpoints; the command stays in the board's
    // -1..10 V and never steps by more than the hard slew (2e5 V/s = 2 V per
    // tick), with the user limits wider than the hard ones in slew.
    for (const bool q31 : {false, true}) {
        SCOPED_TRACE(q31 ? "q31" : "float");
        PipelineSetup su = setup(2e5f);
        PipelineParams p = series_params(2e5f);
        p.limits.u_min_V = -1.0f;
        p.limits.u_max_V = 10.0f;
        p.pid.u_min = -15.0f;  // a feedback able to ask for far more than the range
        p.pid.u_max = 15.0f;
        p.pid.kp = 50.0f;
        std::mt19937 rng(7);
        std::uniform_real_distribution<float> d(-1e6f, 1e6f);
        const float specials[] = {NAN, INFINITY, -INFINITY, 3e38f, -3e38f, 1e-40f};
        float prev = 0.0f;
        auto check = [&](float u) {
            ASSERT_TRUE(std::isfinite(u));
            ASSERT_LE(u, 10.0f);
            ASSERT_GE(u, -1.0f);
            ASSERT_LE(std::fabs(u - prev), 2.0f + 1e-5f);
            prev = u;
        };
        if (!q31) {
            auto pipe = std::make_unique<SeriesPipeline<float>>(su);
            ASSERT_TRUE(pipe->stage(p).ok());
            pipe->arm();
            // Finite first (the command is pinned at both limits), then with
            // NaN and Inf, which trip the limiter and poison the PID's state
            // (the limiter then ramps to its safe output).
            for (int k = 0; k < 100000; ++k) {
                const bool special = k >= 50000;
                pipe->set_setpoint((special && k % 11 == 0) ? specials[(k / 11) % 6] : d(rng));
                check(pipe->tick((special && k % 7 == 0) ? specials[k % 6] : d(rng)));
                if (pipe->limiter().tripped()) pipe->limiter().clear_trip();
                if (k == 49999) {
                    EXPECT_GT(pipe->limiter().clamped_samples(), 1000u);
                }
            }
        } else {
            // Q31 samples cannot be NaN: full-scale extremes instead.
            auto pipe = std::make_unique<SeriesPipeline<Q31>>(su);
            ASSERT_TRUE(pipe->stage(p).ok());
            pipe->arm();
            for (int k = 0; k < 100000; ++k) {
                const Q31 ext[] = {Q31::from_raw(Q31::kMaxRaw), Q31::from_raw(Q31::kMinRaw), Q31{}};
                pipe->set_setpoint(k % 5 == 0 ? ext[k % 3] : su.position.to_sample<Q31>(d(rng) * 1e-5f));
                const Q31 y = k % 3 == 0 ? ext[(k / 3) % 3] : su.position.to_sample<Q31>(d(rng) * 1e-5f);
                check(su.voltage.to_physical(pipe->tick(y)));
            }
            EXPECT_GT(pipe->limiter().clamped_samples(), 1000u);
        }
    }
}

TEST(PipelineSeries, InvalidSetsNameTheirField) {
    auto pipe = std::make_unique<SeriesPipeline<float>>(setup());
    // The compensator follows the feedback: without one there is no series.
    PipelineParams p = series_params();
    p.feedback = FeedbackKind::kNone;
    Status s = pipe->stage(p);
    ASSERT_FALSE(s.ok());
    EXPECT_STREQ(s.field, "feedforward");
    EXPECT_EQ(s.group, nullptr);
    EXPECT_FALSE(pipe->swap_pending());
    EXPECT_FALSE(pipe->validate(p).ok());
    // A bad compensator is the "pi" group's, as for pi_compensator.
    p = series_params();
    p.pi.thresholds[2] = -1.0f;
    s = pipe->stage(p);
    EXPECT_STREQ(s.group, "pi");
    EXPECT_STREQ(s.field, "thresholds");
    // A feedback output range given in µm is validated as the PID's.
    p = series_params();
    p.pid.u_min = 5.0f;
    p.pid.u_max = -5.0f;
    s = pipe->stage(p);
    EXPECT_STREQ(s.group, "pid");
    // RC plugs into the feedback as for the other kinds.
    p = series_params();
    p.rc_enabled = true;
    p.rc.period_samples = 100;
    p.rc.m1 = 3;
    p.rc.k_rc = 0.8f;
    p.rc.q = SosSection{0.3558, 0.0, 0.0, -0.6442, 0.0};
    EXPECT_TRUE(pipe->validate(p).ok());
    EXPECT_TRUE(pipe->validate(series_params()).ok());
    // kPiSeries runs on both sample types.
    auto q = std::make_unique<SeriesPipeline<Q31>>(setup());
    EXPECT_TRUE(q->validate(series_params()).ok());
}

TEST(PipelineSeries, ChangingThePlacementRestartsTheFeedback) {
    // The feedback's output is V beside the compensator and µm before it: a
    // swap between the placements restarts it from rest (and the PI), even
    // with identical feedback parameters; a limits-only change in series
    // resets nothing.
    const PipelineSetup su = setup();
    PipelineParams beside = series_params();
    beside.feedforward = FeedforwardKind::kPiCompensator;
    auto a = std::make_unique<SeriesPipeline<float>>(su);
    auto b = std::make_unique<SeriesPipeline<float>>(su);
    ASSERT_TRUE(a->stage(series_params()).ok());
    ASSERT_TRUE(b->stage(beside).ok());
    a->arm();
    b->arm();
    Drive d;
    int k = 0;
    for (; k < 1500; ++k) {
        a->set_setpoint(d.r_um(k));
        b->set_setpoint(d.r_um(k));
        const float ua = a->tick(d.y_um);
        b->tick(d.y_um);
        d.plant(ua);
    }
    ASSERT_NE(b->last().u_fb, 0.0f);  // the integrator holds something
    // b goes to series while armed: from the swap tick on its blocks run
    // from rest, so its u_fb and u_ff equal those of a fresh Pid and
    // PiOperator fed from that tick.
    ASSERT_TRUE(b->stage(series_params()).ok());
    Pid<float> pid;
    ASSERT_TRUE(pid.configure(pid_um(), su.rate_Hz, su.position, su.position).ok());
    PiOperator<float> pi;
    ASSERT_TRUE(pi.configure(compensator()).ok());
    for (int n = 0; n < 200; ++n, ++k) {
        const float r = d.r_um(k);
        a->set_setpoint(r);
        b->set_setpoint(r);
        const float ua = a->tick(d.y_um);
        b->tick(d.y_um);
        const float u_fb = pid.apply(r - d.y_um);
        ASSERT_EQ(b->last().u_fb, u_fb) << n;
        ASSERT_EQ(b->last().u_ff, pi.apply(r + u_fb)) << n;
        d.plant(ua);
    }
    // A limits-only change (a slew that does not bind either way) keeps
    // every state: bit-identical to a twin that never changed.
    auto c = std::make_unique<SeriesPipeline<float>>(su);
    auto twin = std::make_unique<SeriesPipeline<float>>(su);
    for (auto* x : {c.get(), twin.get()}) {
        ASSERT_TRUE(x->stage(series_params()).ok());
        x->arm();
    }
    Drive dc;
    for (int j = 0; j < 3000; ++j) {
        if (j == 1000) {
            ASSERT_TRUE(c->stage(series_params(5e6f)).ok());
        }
        const float r = dc.r_um(j);
        c->set_setpoint(r);
        twin->set_setpoint(r);
        const float uc = c->tick(dc.y_um);
        ASSERT_EQ(uc, twin->tick(dc.y_um)) << "tick " << j;
        dc.plant(uc);
    }
    EXPECT_EQ(c->swaps(), 2u);
    // Re-arming starts every block from rest (the compensator from the start
    // state for the held setpoint and the command in effect, both the same
    // here: the disarmed tick slews to 0 V at once): equal to a fresh
    // pipeline's.
    auto fresh = std::make_unique<SeriesPipeline<float>>(su);
    ASSERT_TRUE(fresh->stage(series_params()).ok());
    fresh->tick(0.0f);  // swap it in, disarmed
    a->disarm();
    a->tick(0.0f);
    ASSERT_EQ(a->last().u, 0.0f);
    a->set_setpoint(d.r_um(k));
    fresh->set_setpoint(d.r_um(k));
    a->arm();
    fresh->arm();
    for (int n = 0; n < 500; ++n, ++k) {
        const float r = d.r_um(k);
        a->set_setpoint(r);
        fresh->set_setpoint(r);
        const float ua = a->tick(d.y_um);
        fresh->tick(d.y_um);
        ASSERT_EQ(a->last().u_fb, fresh->last().u_fb) << n;
        ASSERT_EQ(a->last().u_ff, fresh->last().u_ff) << n;
        d.plant(ua);
    }
}
