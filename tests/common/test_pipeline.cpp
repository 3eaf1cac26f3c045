// The composed pipeline: closed loop on the reference stage, parameter
// validation and swapping, arming, and the hard limits.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <memory>
#include <random>
#include <vector>

#include "piezoloop/reference_stage.hpp"
#include "sim/metrics.hpp"
#include "sim/reference_loop.hpp"

using namespace piezoloop;

namespace {

template <class T>
using RefPipeline = Pipeline<T, 1024, 4, 1024>;

TrajectoryConfig triangle_10Hz() {
    TrajectoryConfig t;
    t.waveform = Waveform::kTriangle;
    t.amplitude_um = 15.0f;
    t.offset_um = 0.0f;
    t.frequency_Hz = 10.0f;
    t.sample_rate_Hz = reference::kRate_Hz;
    return t;
}

// The last period (10 000 ticks of the 10 Hz triangle) after 0.2 s.
template <class T>
sim::TrackingMetrics run(const PipelineParams& p) {
    const sim::LoopLog log = sim::run_reference_loop<T>(p, triangle_10Hz(), 30000, 10000);
    return sim::tracking_metrics(log.r_um, log.y_um);
}

}  // namespace

TEST(Pipeline, FeedforwardAndFeedbackTrackTheReferenceStage) {
    // 10 Hz, 30 µm p-p triangle on the 15-operator stage, whose simulated
    // weights differ from the model the inverse is built from. Each part must
    // help, and together they must meet Ahmad2020's specification up to
    // 10 Hz: peak error < 1 % of the range.
    const auto open = run<float>(reference::open_loop_params());
    const auto ff = run<float>(reference::params(true, false));
    const auto fb = run<float>(reference::params(false, true));
    const auto both = run<float>(reference::params(true, true));
    std::printf("e_max%%: open %.3f  ff %.3f  fb %.3f  ff+fb %.3f\n", open.e_max_pct, ff.e_max_pct,
                fb.e_max_pct, both.e_max_pct);
    EXPECT_GT(open.e_max_pct, 5.0);  // hysteresis of the bender: several %
    EXPECT_LT(ff.e_max_pct, open.e_max_pct);
    EXPECT_LT(fb.e_max_pct, open.e_max_pct);
    EXPECT_LT(both.e_max_pct, 1.0);
    EXPECT_LT(both.e_max_pct, ff.e_max_pct);
    EXPECT_LT(both.e_max_pct, fb.e_max_pct);
}

TEST(Pipeline, Q31TracksLikeFloat) {
    // Same loop in Q31 (50 µm / 12 V full scales). Quantisation is ~2e-8 of
    // full scale, so the metrics agree with float to well under 0.01 %.
    const auto f = run<float>(reference::params(true, true));
    const auto q = run<Q31>(reference::params(true, true));
    EXPECT_NEAR(q.e_max_pct, f.e_max_pct, 0.01);
    EXPECT_NEAR(q.e_rms_pct, f.e_rms_pct, 0.01);
}

TEST(Pipeline, SwapHappensAtTheNextTickBoundary) {
    auto pipe = std::make_unique<RefPipeline<float>>(reference::setup());
    ASSERT_TRUE(pipe->stage(reference::params()).ok());
    EXPECT_TRUE(pipe->swap_pending());
    EXPECT_EQ(pipe->swaps(), 0u);
    // A second set cannot overwrite one that is not yet live.
    const Status busy = pipe->stage(reference::params(false, true));
    EXPECT_STREQ(busy.field, "params");
    pipe->tick(0.0f);
    EXPECT_FALSE(pipe->swap_pending());
    EXPECT_EQ(pipe->swaps(), 1u);
    EXPECT_EQ(pipe->params().feedforward, FeedforwardKind::kPiInverse);
    ASSERT_TRUE(pipe->stage(reference::params(false, true)).ok());
    EXPECT_EQ(pipe->params().feedforward, FeedforwardKind::kPiInverse);  // not yet
    pipe->tick(0.0f);
    EXPECT_EQ(pipe->params().feedforward, FeedforwardKind::kNone);
}

TEST(Pipeline, InvalidSetsAreRejectedFieldByFieldAndChangeNothing) {
    struct Case {
        const char* group;
        const char* field;
        void (*mutate)(PipelineParams&);
    };
    const Case cases[] = {
        {"pi", "weights", [](PipelineParams& p) { p.pi.weights[2] = -10.0f; }},  // not invertible
        {"pi", "thresholds", [](PipelineParams& p) { p.pi.thresholds[3] = -1.0f; }},
        {"pi", "count", [](PipelineParams& p) { p.pi.count = 40; }},
        {nullptr, "feedforward", [](PipelineParams& p) { p.feedforward = static_cast<FeedforwardKind>(9); }},
        {nullptr, "sos_count", [](PipelineParams& p) { p.sos_count = 5; }},
        {"sos", "sections[1].a2", [](PipelineParams& p) { p.sos[1].a2 = 1.5; }},
        {"sos", "sections[0].b0", [](PipelineParams& p) { p.sos[0].b0 = NAN; }},
        {"rc", "k_rc", [](PipelineParams& p) { p.rc_enabled = true; p.rc.k_rc = 3.0f; }},
        {"rc", "period_samples", [](PipelineParams& p) { p.rc_enabled = true; p.rc.period_samples = 5000; }},
        {nullptr, "rc_enabled", [](PipelineParams& p) { p.rc_enabled = true; p.feedback = FeedbackKind::kNone; }},
        {"limits", "u_max_V", [](PipelineParams& p) { p.limits.u_max_V = 50.0f; }},
        {"limits", "u_min_V", [](PipelineParams& p) { p.limits.u_min_V = NAN; }},
        {"pid", nullptr, [](PipelineParams& p) { p.feedback = FeedbackKind::kPid; p.pid.u_min = 5; p.pid.u_max = -5; }},
        {nullptr, "prefilter_count", [](PipelineParams& p) { p.prefilter_count = 3; }},
        {nullptr, "prefilter[0].a2", [](PipelineParams& p) { p.prefilter_count = 1; p.prefilter[0].a2 = 1.2; }},
    };
    // Reference: a pipeline that never sees a bad set. Subject: the same one
    // offered every bad set between ticks. Their outputs must stay identical.
    auto ref = std::make_unique<RefPipeline<float>>(reference::setup());
    auto sub = std::make_unique<RefPipeline<float>>(reference::setup());
    for (auto* p : {ref.get(), sub.get()}) {
        ASSERT_TRUE(p->stage(reference::params()).ok());
        p->arm();
        ASSERT_TRUE(p->start_wave(triangle_10Hz()).ok());
    }
    float y = 0.0f;
    for (int k = 0; k < 2000; ++k) {
        if (k % 100 == 50) {
            const Case& c = cases[(k / 100) % std::size(cases)];
            PipelineParams bad = reference::params();
            c.mutate(bad);
            const Status s = sub->stage(bad);
            ASSERT_FALSE(s.ok()) << c.field;
            EXPECT_FALSE(sub->swap_pending());
            if (c.group) {
                EXPECT_STREQ(s.group, c.group) << c.field;
            }
            if (c.field) {
                EXPECT_STREQ(s.field, c.field) << (s.field ? s.field : "null");
            }
            EXPECT_FALSE(sub->validate(bad).ok());
        }
        const float a = ref->tick(y), b = sub->tick(y);
        ASSERT_EQ(a, b) << "tick " << k;
        y = 0.9f * y + 0.4f * a;  // a crude plant, identical for both
    }
}

// A bad pre-filter coefficient is named as the feedforward group (and a
// scenario's controller) holds it, "prefilter[i].<coef>", with no group of
// its own: the link reports it as "feedforward.prefilter[i].<coef>", the
// path its field checks use for a non-finite one.
TEST(Pipeline, PreFilterCoefficientsAreNamedAsTheFeedforwardGroupHoldsThem) {
    struct Case {
        const char* field;
        void (*mutate)(SosSection&);
    };
    const Case cases[] = {
        {"prefilter[1].a1", [](SosSection& s) { s.a1 = 3.0; }},
        {"prefilter[1].a2", [](SosSection& s) { s.a2 = -1.0; }},
        {"prefilter[1].b2", [](SosSection& s) { s.b2 = NAN; }},
    };
    for (const Case& c : cases) {
        PipelineParams p = reference::params();
        p.prefilter_count = 2;
        p.prefilter[0] = SosSection{0.02, 0.04, 0.02, -1.56, 0.64};
        p.prefilter[1] = p.prefilter[0];
        c.mutate(p.prefilter[1]);
        for (const bool q31 : {false, true}) {
            Status s;
            if (q31) s = std::make_unique<RefPipeline<Q31>>(reference::setup())->validate(p);
            else s = std::make_unique<RefPipeline<float>>(reference::setup())->validate(p);
            EXPECT_STREQ(s.field, c.field) << (s.field ? s.field : "ok");
            EXPECT_EQ(s.group, nullptr) << s.group;
        }
    }
}

// The reference pre-filter: r as the loop sees and records it is the
// trajectory through the sections (a standalone cascade, the reference),
// armed or not, carried across the arming and across a swap that keeps it;
// a changed pre-filter starts from rest. Without one r is the trajectory.
TEST(Pipeline, ReferencePreFilterShapesTheReferenceArmedOrNot) {
    PipelineParams with = reference::params();
    with.prefilter_count = 2;
    with.prefilter[0] = SosSection{0.02, 0.04, 0.02, -1.56, 0.64};  // a low-pass pair, DC gain 1
    with.prefilter[1] = SosSection{0.5, 0.5, 0.0, 0.0, 0.0};         // an average of two samples
    auto plain = std::make_unique<RefPipeline<float>>(reference::setup());
    auto shaped = std::make_unique<RefPipeline<float>>(reference::setup());
    ASSERT_TRUE(plain->stage(reference::params()).ok());
    ASSERT_TRUE(shaped->stage(with).ok());
    BiquadCascade<float, 2> filter;
    ASSERT_TRUE(filter.configure(with.prefilter.data(), 2, reference::setup().position, reference::setup().position).ok());
    for (auto* p : {plain.get(), shaped.get()}) ASSERT_TRUE(p->start_wave(triangle_10Hz()).ok());
    float y = 0.0f;
    for (int k = 0; k < 3000; ++k) {
        if (k == 1000) {
            plain->arm();
            shaped->arm();
        }
        if (k == 2000) {
            ASSERT_TRUE(shaped->stage(with).ok());  // the same pre-filter: it carries on
        }
        plain->tick(0.0f);
        shaped->tick(y);
        ASSERT_EQ(shaped->last().r, filter.apply(plain->last().r)) << "tick " << k;
        y = shaped->last().u * 1.5f;
    }
    // A changed pre-filter is refused while armed (it would restart from
    // rest inside the running loop), and starts from rest once disarmed: its
    // first output is b0 times r.
    PipelineParams changed = with;
    changed.prefilter[1] = SosSection{0.25, 0.75, 0.0, 0.0, 0.0};
    const Status armed = shaped->stage(changed);
    EXPECT_FALSE(armed.ok());
    EXPECT_STREQ(armed.field, "prefilter");
    shaped->disarm();
    ASSERT_TRUE(shaped->stage(changed).ok());
    plain->tick(0.0f);
    shaped->tick(0.0f);
    EXPECT_FLOAT_EQ(shaped->last().r, 0.02f * 0.25f * plain->last().r);
}

namespace {

// r of the next `ticks` ticks, the loop reading y = 0.
template <class T>
std::vector<T> references(RefPipeline<T>& p, int ticks) {
    std::vector<T> r;
    for (int k = 0; k < ticks; ++k) {
        p.tick(sample_zero<T>());
        r.push_back(p.last().r);
    }
    return r;
}

// A wave's start: r is the approach (approach.hpp, tested against its closed
// form in test_approach.cpp) from `from` to the wave's first value, then the
// wave exactly as a generator of its own produces it from its start.
template <class T>
void expect_approach_then_wave(RefPipeline<T>& p, T from, const TrajectoryConfig& wave, const char* what) {
    const SignalScale pos = reference::setup().position;
    TrajectoryGenerator<T> gen(pos);
    ASSERT_TRUE(gen.configure(wave).ok());
    Approach<T> ref(pos, reference::kRate_Hz);
    const uint32_t n = ref.ticks_for(from, gen.start_value());
    EXPECT_EQ(p.approach_ticks(from), n) << what;
    std::vector<T> expected;
    if (ref.begin(from, gen.start_value())) {
        while (ref.moving()) expected.push_back(ref.step());
    }
    const std::size_t approach = expected.size();
    for (int k = 0; k < 3000; ++k) expected.push_back(gen.step());
    const std::vector<T> r = references(p, static_cast<int>(expected.size()));
    for (std::size_t k = 0; k < r.size(); ++k)
        ASSERT_TRUE(r[k] == expected[k]) << what << ": tick " << k << " of an approach of " << approach;
}

template <class T>
void wave_start_approaches() {
    const SignalScale pos = reference::setup().position;
    // Loop armed and holding a setpoint of 5 um: the triangle (first value
    // -15 um) is approached from the setpoint, 20 um at 500 um/s: 7500 ticks.
    {
        auto p = std::make_unique<RefPipeline<T>>(reference::setup());
        ASSERT_TRUE(p->stage(reference::params(false, true)).ok());
        p->arm();
        ASSERT_TRUE(p->set_setpoint(pos.to_sample<T>(5.0f)));
        (void)references(*p, 10);
        ASSERT_TRUE(p->start_wave(triangle_10Hz()).ok());
        EXPECT_NEAR(p->approach_ticks(pos.to_sample<T>(5.0f)), 7500.0, 1.0);
        expect_approach_then_wave(*p, pos.to_sample<T>(5.0f), triangle_10Hz(), "armed, from the setpoint");
    }
    // Disarmed, the stage reading 3 um; armed with the wave: from the reading.
    {
        auto p = std::make_unique<RefPipeline<T>>(reference::setup());
        ASSERT_TRUE(p->stage(reference::params(false, true)).ok());
        p->tick(pos.to_sample<T>(3.0f));
        p->arm();
        ASSERT_TRUE(p->start_wave(triangle_10Hz()).ok());
        expect_approach_then_wave(*p, pos.to_sample<T>(3.0f), triangle_10Hz(), "arming, from the reading");
    }
    // The stage at the wave's first point (0 um): no approach, the wave from
    // its first tick, as before there was one.
    {
        TrajectoryConfig from_zero = triangle_10Hz();
        from_zero.offset_um = 15.0f;
        auto p = std::make_unique<RefPipeline<T>>(reference::setup());
        ASSERT_TRUE(p->stage(reference::params(false, true)).ok());
        p->arm();
        ASSERT_TRUE(p->start_wave(from_zero).ok());
        EXPECT_EQ(p->approach_ticks(sample_zero<T>()), 0u);
        expect_approach_then_wave(*p, sample_zero<T>(), from_zero, "at the first point");
    }
    // Stopped during the approach: the setpoint holds where r was.
    {
        auto p = std::make_unique<RefPipeline<T>>(reference::setup());
        ASSERT_TRUE(p->stage(reference::params(false, true)).ok());
        p->arm();
        ASSERT_TRUE(p->start_wave(triangle_10Hz()).ok());
        (void)references(*p, 1000);
        EXPECT_TRUE(p->approaching());
        p->stop_wave();
        p->tick(sample_zero<T>());
        const T held = p->last().r;
        EXPECT_FALSE(p->wave_running());
        EXPECT_FALSE(p->approaching());
        for (const T r : references(*p, 100)) ASSERT_TRUE(r == held);
        // The next wave approaches from there.
        ASSERT_TRUE(p->start_wave(triangle_10Hz()).ok());
        expect_approach_then_wave(*p, held, triangle_10Hz(), "after a stop");
    }
}

}  // namespace

TEST(Pipeline, AWaveStartsWithASmoothApproachFromWhereTheLoopIs) { wave_start_approaches<float>(); }
TEST(Pipeline, AQ31WaveStartsWithASmoothApproachFromWhereTheLoopIs) { wave_start_approaches<Q31>(); }

namespace {

// A wave stopped mid-way, the loop disarmed and the stage come to rest at
// 1.5 um while the pre-filter runs on the held setpoint (the stopped wave's
// last point, ~8 um away); then the next wave is started, arming the loop at
// its first tick. Its approach starts from the reading, and so must the
// filtered r: its first value is the reading (within 1e-5 um: float
// rounding at ~15 um, a few Q31 LSB of 50 um), every step of r through the
// approach within the approach's bound v_max / rate (5 % over it for the
// low-pass pair's slight overshoot on a smooth move; a step through the
// filter of the ~8 um between setpoint and reading would be ~1000 times
// it), and the first ticks leave the reading at rest, within the minimum-
// jerk start 10 D (k / N)^3 + 1e-5 um.
template <class T>
void wave_after_a_stopped_one_starts_where_the_stage_is() {
    const SignalScale pos = reference::setup().position;
    PipelineParams p = reference::params(false, true);
    p.prefilter_count = 1;
    p.prefilter[0] = SosSection{0.02, 0.04, 0.02, -1.56, 0.64};  // a low-pass pair, DC gain 1
    auto pipe = std::make_unique<RefPipeline<T>>(reference::setup());
    ASSERT_TRUE(pipe->stage(p).ok());
    T y = sample_zero<T>();
    auto tick = [&](T reading) {
        pipe->tick(reading);
        return pos.to_physical(pipe->last().r);
    };
    pipe->arm();
    ASSERT_TRUE(pipe->start_wave(triangle_10Hz()).ok());
    for (int k = 0; k < 12000; ++k) {  // the approach to -15 um, then 0.06 s of the triangle
        (void)tick(y);
        y = pipe->last().r;  // an ideal stage: where r was
    }
    ASSERT_TRUE(pipe->wave_running());
    EXPECT_FALSE(pipe->approaching());
    pipe->stop_wave();
    (void)tick(y);
    pipe->disarm();
    const T rest = pos.to_sample<T>(1.5f);
    for (int k = 0; k < 1900; ++k) (void)tick(rest);
    const float held_um = tick(rest);
    for (int k = 0; k < 100; ++k) ASSERT_NEAR(tick(rest), held_um, 1e-5) << "disarmed, the pre-filter holds the setpoint";
    ASSERT_GT(std::fabs(held_um - 1.5f), 5.0f);

    pipe->arm();
    ASSERT_TRUE(pipe->start_wave(triangle_10Hz()).ok());
    const float from_um = 1.5f, to_um = -15.0f;
    const double d_um = std::fabs(to_um - from_um);
    const double n = std::ceil(d_um / (8.0 / 15.0 * 10.0 * 50.0 / reference::kRate_Hz));
    std::vector<float> r;  // the approach's ticks (the triangle then runs at 600 um/s, above the bound)
    EXPECT_EQ(pipe->approach_ticks(rest), static_cast<uint32_t>(n));
    for (int k = 0; k + 1 < static_cast<int>(n); ++k) r.push_back(tick(rest));
    EXPECT_NEAR(r[0], from_um, 1e-5) << "the filtered r starts at the reading";
    for (int k = 0; k < 5; ++k) {
        const double x = (k + 1) / n;
        EXPECT_LE(std::fabs(r[static_cast<std::size_t>(k)] - from_um), 10.0 * d_um * x * x * x + 1e-5) << "tick " << k;
    }
    const double bound = 10.0 * 50.0 / reference::kRate_Hz;
    double largest = std::fabs(r[0] - from_um);
    for (std::size_t k = 1; k < r.size(); ++k) largest = std::max(largest, static_cast<double>(std::fabs(r[k] - r[k - 1])));
    EXPECT_LE(largest, 1.05 * bound) << "largest step of the filtered r (um)";
}

}  // namespace

TEST(Pipeline, AWaveAfterAStoppedOneStartsThroughThePreFilterWhereTheStageIs) {
    wave_after_a_stopped_one_starts_where_the_stage_is<float>();
}
TEST(Pipeline, AQ31WaveAfterAStoppedOneStartsThroughThePreFilterWhereTheStageIs) {
    wave_after_a_stopped_one_starts_where_the_stage_is<Q31>();
}

TEST(Pipeline, DahlFeedforwardRunsInBothPipelines) {
    // Dahl feedforward alone (no feedback), a 6 um triangle. The float
    // pipeline's u_ff is DahlFeedforward's output; the Q31 pipeline runs the
    // same float model on r converted to um and converts u_ff to its voltage
    // sample: bit for bit what the block computes on those values (software
    // float on the M3 gives the same IEEE results), and within float
    // rounding of the float pipeline.
    // Light path damping (alpha1) keeps the start transient, and with beta1
    // the branch gap, over the 4 cycles.
    const DahlParams d{0.05f, 1.0f, 1.0f, 0.5f, 0.4f, 1.2f};
    PipelineParams p = reference::params();
    p.feedforward = FeedforwardKind::kDahl;
    p.dahl = d;
    p.feedback = FeedbackKind::kNone;
    p.rc_enabled = false;
    const PipelineSetup su = reference::setup();
    auto f = std::make_unique<RefPipeline<float>>(su);
    auto q = std::make_unique<RefPipeline<Q31>>(su);
    ASSERT_TRUE(f->stage(p).ok());
    ASSERT_TRUE(q->stage(p).ok());
    f->arm();
    q->arm();
    DahlFeedforward ref;
    ASSERT_TRUE(ref.configure(d).ok());
    ref.reset(0.0f);
    double worst_V = 0.0, loop_V = 0.0;
    for (int k = 0; k < 4000; ++k) {
        const int phase = k % 1000;
        const float r_um = 6.0f * static_cast<float>(phase < 500 ? phase : 1000 - phase) / 500.0f;
        const Q31 r_q = su.position.to_sample<Q31>(r_um);
        f->set_setpoint(r_um);
        q->set_setpoint(r_q);
        f->tick(0.0f);
        q->tick(Q31::from_raw(0));
        const Q31 want = su.voltage.to_sample<Q31>(ref.step(su.position.to_physical(r_q)));
        ASSERT_EQ(q->last().u_ff.raw(), want.raw()) << "tick " << k;
        const double uq = su.voltage.to_physical(q->last().u_ff), uf = f->last().u_ff;
        worst_V = std::max(worst_V, std::fabs(uq - uf));
        if (k >= 3000 && phase == 250) loop_V = uf;
        if (k >= 3000 && phase == 750) loop_V -= uf;  // same r, other branch
    }
    // r in Q31 is within 1.2e-8 um of r and float rounding of r (an ulp of
    // 6 um is 4.8e-7 um) moves H by about as much; the Q31 command adds half
    // an LSB of 12 V (2.8e-9 V). 1e-5 V is ~10x what that allows.
    EXPECT_LT(worst_V, 1e-5);
    EXPECT_GT(std::fabs(loop_V), 0.01);  // the feedforward is hysteretic: not a trivial pass
    std::printf("Dahl feedforward, Q31 vs float pipeline: worst %.3g V; branch gap at mid-range %.3f V\n",
                worst_V, std::fabs(loop_V));
}

TEST(Pipeline, OutputNeverLeavesHardLimitsWhateverTheInput) {
    // Hostile measurements (NaN, Inf, huge) and hostile references: the
    // command stays within the board's ±10 V and never steps faster than the
    // hard slew (2e5 V/s = 2 V per tick).
    auto pipe = std::make_unique<RefPipeline<float>>(reference::setup());
    ASSERT_TRUE(pipe->stage(reference::params(true, true, true)).ok());
    pipe->arm();
    std::mt19937 rng(5);
    std::uniform_real_distribution<float> d(-1e6f, 1e6f);
    const float specials[] = {NAN, INFINITY, -INFINITY, 3e38f, -3e38f, 1e-40f};
    float prev = 0.0f;
    for (int k = 0; k < 200000; ++k) {
        const float y = (k % 7 == 0) ? specials[k % 6] : d(rng);
        pipe->set_setpoint((k % 11 == 0) ? specials[(k / 11) % 6] : d(rng));
        const float u = pipe->tick(y);
        ASSERT_TRUE(std::isfinite(u));
        ASSERT_LE(u, 10.0f);
        ASSERT_GE(u, -10.0f);
        ASSERT_LE(std::fabs(u - prev), 2.0f + 1e-6f);
        prev = u;
        if (pipe->limiter().tripped()) pipe->limiter().clear_trip();
    }
    EXPECT_GT(pipe->rejected_setpoints(), 0u);  // the NaN/Inf setpoints, counted
}

TEST(Pipeline, DisarmRampsToTheSafeOutput) {
    auto pipe = std::make_unique<RefPipeline<float>>(reference::setup());
    ASSERT_TRUE(pipe->stage(reference::params()).ok());
    pipe->arm();
    pipe->set_setpoint(30.0f);  // feedforward alone asks for ~6.9 V
    float u = 0.0f;
    for (int k = 0; k < 100; ++k) u = pipe->tick(30.0f);
    EXPECT_GT(u, 5.0f);
    pipe->disarm();
    u = pipe->tick(30.0f);
    EXPECT_GT(u, 0.0f);  // slewing, no jump
    for (int k = 0; k < 100; ++k) u = pipe->tick(30.0f);
    EXPECT_EQ(u, 0.0f);
}

TEST(Pipeline, UnchangedBlocksKeepTheirStateAcrossASwap) {
    // Twin pipelines on identical inputs. Mid-run one of them is given the
    // same controller with only a limit changed (not binding here): nothing
    // is reset, so their outputs stay bit-identical. Then it is given a new
    // feedback gain: from that swap on they differ, while the feedforward
    // (unchanged) keeps its play states — its output equals the twin's.
    auto a = std::make_unique<RefPipeline<float>>(reference::setup());
    auto b = std::make_unique<RefPipeline<float>>(reference::setup());
    for (auto* p : {a.get(), b.get()}) {
        ASSERT_TRUE(p->stage(reference::params()).ok());
        p->arm();
        ASSERT_TRUE(p->start_wave(triangle_10Hz()).ok());
    }
    float y = 0.0f;
    for (int k = 0; k < 6000; ++k) {
        if (k == 2000) {
            PipelineParams p = reference::params();
            p.limits.u_max_V = 9.5f;
            ASSERT_TRUE(b->stage(p).ok());
        }
        if (k == 4000) {
            PipelineParams p = reference::params();
            p.limits.u_max_V = 9.5f;
            p.sos[2].b0 *= 1.01;
            p.sos[2].b1 *= 1.01;
            p.sos[2].b2 *= 1.01;
            ASSERT_TRUE(b->stage(p).ok());
        }
        const float ua = a->tick(y), ub = b->tick(y);
        if (k < 4000) {
            ASSERT_EQ(ua, ub) << "tick " << k;
        }
        ASSERT_EQ(a->last().u_ff, b->last().u_ff) << "tick " << k;
        y = 0.95f * y + 0.2f * ua;  // same input for both
    }
    EXPECT_EQ(b->swaps(), 3u);
    EXPECT_NE(a->last().u_fb, b->last().u_fb);
}

TEST(Pipeline, RepetitiveChangeWhileArmedWaitsForThePeriodBoundary) {
    auto pipe = std::make_unique<RefPipeline<float>>(reference::setup());
    ASSERT_TRUE(pipe->stage(reference::params(true, true, true)).ok());
    pipe->arm();
    for (int k = 0; k < 137; ++k) pipe->tick(0.0f);  // armed from tick 0: the RC runs every tick
    PipelineParams p = reference::params(true, true, true);
    p.rc.k_rc = 0.5f;
    ASSERT_TRUE(pipe->stage(p).ok());
    int swapped_at = -1;
    for (int k = 137; k < 400 && swapped_at < 0; ++k) {
        pipe->tick(0.0f);
        if (!pipe->swap_pending()) swapped_at = k;
    }
    // When tick k starts the RC has run ticks 0..k-1; its phase is 0 again
    // after 200 of them: the swap happens at tick 200, not at 137.
    EXPECT_EQ(swapped_at, 200);
    EXPECT_FLOAT_EQ(pipe->params().rc.k_rc, 0.5f);
    // Disarmed, a change applies at the next tick.
    pipe->disarm();
    pipe->tick(0.0f);
    p.rc.k_rc = 0.3f;
    ASSERT_TRUE(pipe->stage(p).ok());
    pipe->tick(0.0f);
    EXPECT_FALSE(pipe->swap_pending());
}

// A limits set that validates in volts but is empty at the Q31 output
// resolution (0 .. 1 nV at 12 V full scale: no Q31 code inside) is refused
// by stage() with its field, not accepted and then dropped at the swap.
TEST(Pipeline, LimitsEmptyAtQ31ResolutionAreRejectedWhenStaged) {
    auto pipe = std::make_unique<RefPipeline<Q31>>(reference::setup());
    PipelineParams p = reference::params();
    p.limits.u_min_V = 0.0f;
    p.limits.u_max_V = 1e-9f;
    const Status s = pipe->stage(p);
    ASSERT_FALSE(s.ok());
    EXPECT_STREQ(s.group, "limits");
    EXPECT_STREQ(s.field, "u_max_V");
    EXPECT_FALSE(pipe->swap_pending());
    EXPECT_FALSE(pipe->validate(p).ok());
    // The same set is fine for the float pipeline (no output quantisation).
    auto f = std::make_unique<RefPipeline<float>>(reference::setup());
    EXPECT_TRUE(f->stage(p).ok());
}
