// Trajectory generator against analytic waveforms computed here in long
// double (std::sin and the piecewise-linear definitions of scipy.signal's
// sawtooth / square), with exact rational phases n * f / f_s.
#include <gtest/gtest.h>

#include <cmath>
#include <cstdint>
#include <numbers>
#include <random>
#include <vector>

#include "piezoloop/sine_table.hpp"
#include "piezoloop/trajectory.hpp"

using piezoloop::Q31;
using piezoloop::SignalScale;
using piezoloop::TrajectoryConfig;
using piezoloop::TrajectoryGenerator;
using piezoloop::Waveform;

namespace {

constexpr long double kTwoPi = 2.0L * std::numbers::pi_v<long double>;
constexpr long double kLsb = 1.0L / 2147483648.0L;  // one Q31 LSB of the shape
// Documented bound of sine_q31: interpolation (pi/2/1024)^2/8 plus 1 LSB of rounding.
constexpr long double kSineErr = 2.95e-7L;

// Phase fraction of sample n for f / f_s = num / den, plus a start phase.
long double phase_of(int64_t n, int64_t num, int64_t den, long double start = 0.0L) {
    const long double x = static_cast<long double>((n * num) % den) / den + start;
    return x >= 1.0L ? x - 1.0L : x;
}

// scipy.signal.sawtooth(2 pi x, width) and square(2 pi x, duty).
long double sawtooth(long double x, long double width) {
    return x < width ? -1.0L + 2.0L * x / width : 1.0L - 2.0L * (x - width) / (1.0L - width);
}
long double square(long double x, long double duty) { return x < duty ? 1.0L : -1.0L; }

// One float ulp at |v|: the resolution of the float output there.
long double ulp_at(float v) {
    const float a = std::fabs(v);
    return static_cast<long double>(std::nextafter(a, INFINITY) - a);
}

TrajectoryConfig base(Waveform w, float amp, float off, float f, float fs = 100000.0f) {
    TrajectoryConfig c;
    c.waveform = w;
    c.amplitude_um = amp;
    c.offset_um = off;
    c.frequency_Hz = f;
    c.sample_rate_Hz = fs;
    return c;
}

}  // namespace

// ---- sine table ------------------------------------------------------------

TEST(SineTable, EntriesAreCorrectlyRoundedSine) {
    // Each entry is sin(2 pi i / 4096) rounded to Q31: within half an LSB
    // (plus 1e-6 LSB for the double series' own rounding, ~1e-16).
    for (std::size_t i = 0; i <= 1024; ++i) {
        const long double exact = std::sin(kTwoPi * i / 4096.0L) * 2147483648.0L;
        const long double want = std::fmin(exact, 2147483647.0L);
        EXPECT_LE(std::fabs(piezoloop::kSineQuarterQ31[i] - want), 0.5L + 1e-6L) << i;
    }
}

TEST(SineTable, InterpolatedSineWithinStatedError) {
    // All knots, all segment midpoints (where the interpolation error peaks),
    // and 1e6 random phases over the full cycle.
    std::mt19937 rng(7);
    long double max_err = 0.0L;
    auto check = [&](uint32_t p) {
        const long double exact = std::sin(kTwoPi * p / 4294967296.0L);
        const long double err = std::fabs(piezoloop::sine_q31(p) * kLsb - exact);
        max_err = std::fmax(max_err, err);
        return err;
    };
    for (uint32_t k = 0; k < 4096; ++k) {
        EXPECT_LE(check(k << 20), 1.0L * kLsb) << k;  // knots: table rounding only
        EXPECT_LE(check((k << 20) + (1u << 19)), kSineErr) << k;
    }
    for (int i = 0; i < 1'000'000; ++i) ASSERT_LE(check(rng()), kSineErr);
    // The bound is tight: the midpoint error near the peak is h^2/8 = 2.94e-7.
    EXPECT_GT(max_err, 2.9e-7L);
    // Symmetry is exact: sin(-x) = -sin(x).
    for (int i = 0; i < 10000; ++i) {
        const uint32_t p = rng();
        if (p == 0 || p == 0x80000000u) continue;
        EXPECT_EQ(piezoloop::sine_q31(p), -piezoloop::sine_q31(0u - p)) << p;
    }
}

// ---- waveforms against analytic values -------------------------------------

// The ramp x -> x * 2^32 / len as the generator evaluates it (the shift on
// the product's two words) equals the plain 64-bit (x * mul) >> shift and
// is at most 2 LSB below the exact floor(x * 2^32 / len), for lengths of
// every shift 0..31 (len 2 .. 2^32 - 1) at both ends and at random x.
TEST(TrajectoryRamp, WordShiftEqualsThe64BitShift) {
    using piezoloop::trajectory_detail::apply_ramp;
    using piezoloop::trajectory_detail::make_ramp;
    std::mt19937_64 rng(7);
    for (int b = 1; b <= 32; ++b) {
        const uint64_t lens[3] = {(uint64_t{1} << (b - 1)) + 1u, (uint64_t{1} << b) - 1u,
                                  (uint64_t{1} << (b - 1)) + (rng() % (uint64_t{1} << (b - 1)))};
        for (const uint64_t len : lens) {
            if (len < 2) continue;
            const auto r = make_ramp(len);
            for (int k = 0; k < 200; ++k) {
                const uint32_t x = k == 0 ? 0u : (k == 1 ? static_cast<uint32_t>(len - 1) : static_cast<uint32_t>(rng() % len));
                const uint64_t plain = (uint64_t{x} * r.mul) >> r.shift;
                ASSERT_EQ(apply_ramp(r, x), plain) << "len " << len << " x " << x;
                const uint64_t exact = (uint64_t{x} << 32) / len;  // x < 2^32: fits
                ASSERT_LE(plain, exact);
                ASSERT_LE(exact - plain, 2u) << "len " << len << " x " << x;
            }
        }
    }
}

TEST(Trajectory, SineMatchesAnalytic) {
    // 1 kHz at 100 kHz: phase n / 100 exactly. Float error: table error times
    // the amplitude, plus the float rounding of the shape, product and sum
    // (<= 2 ulp of the output magnitude).
    TrajectoryGenerator<float> g;
    TrajectoryConfig c = base(Waveform::kSine, 12.0f, 6.0f, 1000.0f);
    c.start_phase_cycles = 0.25f;
    ASSERT_TRUE(g.configure(c).ok());
    const long double tol = 12.0L * kSineErr + 2.0L * ulp_at(18.0f);
    for (int n = 0; n < 1000; ++n) {
        const long double x = phase_of(n, 1, 100, 0.25L);
        const long double want = 6.0L + 12.0L * std::sin(kTwoPi * x);
        ASSERT_NEAR(g.step(), want, tol) << n;
    }
}

TEST(Trajectory, SineAtNonDividingFrequency) {
    // 333 Hz at 100 kHz: phase n * 333 / 100000, not representable by a plain
    // 32-bit increment; the rational accumulator is within one phase LSB
    // (2 pi A / 2^32 = 1.5e-9 A) of it at every sample.
    TrajectoryGenerator<float> g;
    ASSERT_TRUE(g.configure(base(Waveform::kSine, 10.0f, 0.0f, 333.0f)).ok());
    EXPECT_EQ(g.exact_period_samples(), 100000u);
    const long double tol = 10.0L * (kSineErr + kTwoPi * 0x1p-32L) + 2.0L * ulp_at(10.0f);
    for (int n = 0; n < 250000; ++n) {
        const long double want = 10.0L * std::sin(kTwoPi * phase_of(n, 333, 100000));
        ASSERT_NEAR(g.step(), want, tol) << n;
    }
}

TEST(Trajectory, TriangleAtKnownPhases) {
    // Triangle = sawtooth width 1/2: -1 at 0, +1 at 1/2. Shape error <= 2 Q31
    // LSB (the ramp's reciprocal is floored), plus float rounding.
    TrajectoryGenerator<float> g;
    ASSERT_TRUE(g.configure(base(Waveform::kTriangle, 6.0f, 6.0f, 1000.0f)).ok());
    const long double tol = 6.0L * 2.0L * kLsb + 2.0L * ulp_at(12.0f);
    std::vector<float> y(200);
    for (auto& v : y) v = g.step();
    EXPECT_NEAR(y[0], 0.0L, tol);    // bottom
    EXPECT_NEAR(y[25], 6.0L, tol);   // mid-way up
    EXPECT_NEAR(y[50], 12.0L, tol);  // top
    EXPECT_NEAR(y[75], 6.0L, tol);
    EXPECT_NEAR(y[100], 0.0L, tol);
    for (int n = 0; n < 200; ++n) {
        const long double want = 6.0L + 6.0L * sawtooth(phase_of(n, 1, 100), 0.5L);
        EXPECT_NEAR(y[n], want, tol) << n;
    }
}

TEST(Trajectory, RasterSawtoothWithReturnFraction) {
    TrajectoryGenerator<float> g;
    TrajectoryConfig c = base(Waveform::kRaster, 5.0f, 0.0f, 440.0f);
    c.return_fraction = 0.2f;
    ASSERT_TRUE(g.configure(c).ok());
    // The split between ramp and return is rounded to a phase LSB (2^-32):
    // negligible, but a sample right at it may fall on either side; 440/1e5
    // puts no sample within 1e-6 of it, so compare everywhere.
    const long double width = 1.0L - static_cast<long double>(0.2f);
    const long double tol = 5.0L * (2.0L * kLsb + 2.0L * 0x1p-32L / 0.2L) + 2.0L * ulp_at(5.0f);
    for (int n = 0; n < 20000; ++n) {
        const long double x = phase_of(n, 440, 100000);
        ASSERT_NEAR(g.step(), 5.0L * sawtooth(x, width), tol) << n;
    }
}

TEST(Trajectory, SquareAndSteps) {
    TrajectoryGenerator<float> g;
    TrajectoryConfig c = base(Waveform::kSquare, 2.0f, 1.0f, 1000.0f);
    c.duty = 0.3f;
    ASSERT_TRUE(g.configure(c).ok());
    for (int n = 0; n < 300; ++n) {
        // Square levels are +-(1 - 2^-31): 2 * 2^-31 from +-1, far below float resolution at 3.
        EXPECT_NEAR(g.step(), 1.0L + 2.0L * square(phase_of(n, 1, 100), static_cast<long double>(0.3f)), ulp_at(3.0f)) << n;
    }

    const float levels[] = {-1.0f, 0.5f, 0.25f, 1.0f, 0.0f};
    TrajectoryGenerator<float, 8> s;
    TrajectoryConfig d = base(Waveform::kSteps, 4.0f, 0.0f, 200.0f);  // 500 samples per cycle, 100 per level
    d.table = levels;
    ASSERT_TRUE(s.configure(d).ok());
    for (int n = 0; n < 1500; ++n) {
        const float want = 4.0f * levels[(n % 500) / 100];
        EXPECT_NEAR(s.step(), want, 4.0 * kLsb + ulp_at(4.0f)) << n;
    }
}

TEST(Trajectory, WaveTableIsLinearlyInterpolatedAndPeriodic) {
    const float table[] = {0.0f, 1.0f, -0.5f, 0.25f};
    TrajectoryGenerator<float, 16> g;
    TrajectoryConfig c = base(Waveform::kTable, 8.0f, -2.0f, 250.0f);  // 400 samples per cycle
    c.table = table;
    ASSERT_TRUE(g.configure(c).ok());
    // Table values are rounded to Q31 (0.5 LSB), the interpolation to 1 LSB.
    const long double tol = 8.0L * 2.0L * kLsb + 2.0L * ulp_at(6.0f);
    for (int n = 0; n < 1200; ++n) {
        const long double pos = phase_of(n, 1, 400) * 4.0L;
        const int i = static_cast<int>(pos);
        const long double t = pos - i;
        const long double w = table[i] + (table[(i + 1) % 4] - table[i]) * t;
        ASSERT_NEAR(g.step(), -2.0L + 8.0L * w, tol) << n;
    }
}

// ---- phase accumulator -----------------------------------------------------

TEST(Trajectory, PeriodIsExactInSamplesWhenTheFrequencyDividesTheRate) {
    struct Case { float f; uint32_t period; };
    // f divides 100 kHz; 30 Hz and 3 kHz are rational: 3/10000, 3/100.
    const Case cases[] = {{1000.0f, 100}, {12.5f, 8000}, {1.0f, 100000}, {25000.0f, 4}, {30.0f, 10000}, {3000.0f, 100}};
    for (const Case& k : cases) {
        for (Waveform w : {Waveform::kSine, Waveform::kTriangle}) {
            TrajectoryGenerator<float> g;
            ASSERT_TRUE(g.configure(base(w, 1.0f, 0.0f, k.f)).ok());
            EXPECT_EQ(g.exact_period_samples(), k.period) << k.f;
            std::vector<float> first(k.period);
            const uint32_t p0 = g.phase();
            for (auto& v : first) v = g.step();
            EXPECT_EQ(g.phase(), p0) << k.f;  // back exactly where it started
            for (int rep = 0; rep < 3; ++rep) {
                for (uint32_t n = 0; n < k.period; ++n) ASSERT_EQ(g.step(), first[n]) << k.f << " " << n;
            }
            EXPECT_DOUBLE_EQ(g.actual_frequency_Hz(), k.f);
        }
    }
}

TEST(Trajectory, FrequencyChangeKeepsThePhase) {
    TrajectoryGenerator<float> g;
    const float A = 5.0f;
    ASSERT_TRUE(g.configure(base(Waveform::kTriangle, A, 0.0f, 1000.0f)).ok());
    const double inc_old = 4294967296.0 * 1000.0 / 100000.0;
    const double inc_new = 4294967296.0 * 1370.5 / 100000.0;
    uint32_t prev_phase = g.phase();
    float prev = g.step();
    for (int n = 1; n < 537; ++n) {  // stop mid-cycle
        const uint32_t p = g.phase();
        const double d = static_cast<double>(p - prev_phase);
        EXPECT_GE(d, std::floor(inc_old));
        EXPECT_LE(d, std::ceil(inc_old));
        prev_phase = p;
        prev = g.step();
    }
    const uint32_t before = g.phase();
    ASSERT_TRUE(g.set_frequency(1370.5f).ok());
    EXPECT_EQ(g.phase(), before);  // set_frequency itself does not move the phase
    // Output slope bound: |dy| <= 4 A f / f_s per sample for the triangle (plus
    // 2 LSB of shape and float rounding); across the change at most the larger
    // of the old and new increments.
    const long double tol = 4.0L * A * kLsb + 4.0L * ulp_at(A);
    bool first = true;
    for (int n = 0; n < 2000; ++n) {
        const uint32_t p = g.phase();
        const double d = static_cast<double>(p - prev_phase);
        if (first) {
            // The step that straddles the change used the old increment.
            EXPECT_GE(d, std::floor(inc_old));
            EXPECT_LE(d, std::ceil(inc_old));
        } else {
            EXPECT_GE(d, std::floor(inc_new));
            EXPECT_LE(d, std::ceil(inc_new));
        }
        prev_phase = p;
        const float y = g.step();
        const long double max_step = 4.0L * A * (first ? 1000.0L : 1370.5L) / 100000.0L;
        EXPECT_LE(std::fabs(static_cast<long double>(y) - prev), max_step + tol) << n;
        prev = y;
        first = false;
    }
    EXPECT_NEAR(g.actual_frequency_Hz(), 1370.5, 1e-9);

    // Exactness across the change: 537 samples at 1/100 cycle, then 2000 at
    // 2741/200000 cycle. In LSB * 200000: 537 * 2000 * 2^32 + m * 2741 * 2^32.
    // phase() is that exact phase rounded up to an LSB, modulo 2^32.
    TrajectoryGenerator<float> h;
    ASSERT_TRUE(h.configure(base(Waveform::kTriangle, A, 0.0f, 1000.0f)).ok());
    for (int n = 0; n < 537; ++n) h.step();
    ASSERT_TRUE(h.set_frequency(1370.5f).ok());
    for (uint64_t m = 0; m < 2000; ++m) {
        const uint64_t num = (537u * 2000u + m * 2741u) << 32;  // < 2^63
        const uint64_t want = (num + 199999u) / 200000u;        // ceil
        ASSERT_EQ(h.phase(), static_cast<uint32_t>(want)) << m;
        h.step();
    }
}

TEST(Trajectory, CyclesThenHoldsTheFinalValue) {
    TrajectoryGenerator<float> g;
    TrajectoryConfig c = base(Waveform::kSine, 3.0f, 1.0f, 1000.0f);
    c.cycles = 3;
    c.start_phase_cycles = 0.75f;  // starts at the minimum, 1 - 3 = -2
    ASSERT_TRUE(g.configure(c).ok());
    const float start = g.value_at(g.phase());
    EXPECT_NEAR(start, -2.0f, 3.0 * kSineErr + ulp_at(2.0f));
    for (int n = 0; n < 300; ++n) {
        EXPECT_FALSE(g.done()) << n;
        EXPECT_EQ(g.cycles_completed(), static_cast<uint32_t>(n / 100));
        g.step();
    }
    EXPECT_TRUE(g.done());
    EXPECT_EQ(g.cycles_completed(), 3u);
    for (int n = 0; n < 50; ++n) EXPECT_EQ(g.step(), start);
    g.restart();
    EXPECT_FALSE(g.done());
    EXPECT_EQ(g.step(), start);
}

TEST(Trajectory, Q31MatchesFloat) {
    // Same configuration, same integer phase. Q31: offset and amplitude
    // rounded to 0.5 LSB each, the product to 0.5 LSB -> 1.5 LSB. Float:
    // shape conversion, product and sum each <= 0.5 ulp of the output range.
    // Tolerance: 1.5 Q31 LSB + 2 float ulp of |offset| + amplitude.
    const float fs = 50.0f;
    for (Waveform w : {Waveform::kSine, Waveform::kTriangle, Waveform::kRaster, Waveform::kSquare, Waveform::kTable}) {
        const float table[] = {0.1f, -0.9f, 0.7f};
        TrajectoryConfig c = base(w, 20.0f, 5.0f, 777.0f);
        c.return_fraction = 0.15f;
        c.start_phase_cycles = 0.3f;
        c.table = table;
        TrajectoryGenerator<float, 4> gf;
        TrajectoryGenerator<Q31, 4> gq(SignalScale{fs});
        ASSERT_TRUE(gf.configure(c).ok());
        ASSERT_TRUE(gq.configure(c).ok());
        const long double tol = 1.5L * fs * kLsb + 2.0L * ulp_at(25.0f);
        for (int n = 0; n < 100000; ++n) {
            ASSERT_EQ(gf.phase(), gq.phase());
            const long double q = gq.step().raw() * kLsb * fs;
            const long double f = gf.step();
            ASSERT_NEAR(q, f, tol) << static_cast<int>(w) << " " << n;
        }
    }
}

// ---- configuration ---------------------------------------------------------

TEST(Trajectory, ValidationNamesTheFieldAndKeepsTheOldConfiguration) {
    TrajectoryGenerator<float, 4> g;
    TrajectoryGenerator<float, 4> ref;
    const TrajectoryConfig good = base(Waveform::kTriangle, 2.0f, 1.0f, 1000.0f);
    ASSERT_TRUE(g.configure(good).ok());
    ASSERT_TRUE(ref.configure(good).ok());
    for (int i = 0; i < 37; ++i) { g.step(); ref.step(); }

    const float too_long[] = {0, 0, 0, 0, 0};
    const float out_of_range[] = {0.0f, 1.5f};
    struct Case { TrajectoryConfig c; const char* field; };
    std::vector<Case> cases;
    auto with = [&](auto edit, const char* field) { TrajectoryConfig c = good; edit(c); cases.push_back({c, field}); };
    with([](TrajectoryConfig& c) { c.frequency_Hz = 0.0f; }, "frequency_Hz");
    with([](TrajectoryConfig& c) { c.frequency_Hz = 50000.0f; }, "frequency_Hz");  // = rate / 2
    with([](TrajectoryConfig& c) { c.frequency_Hz = NAN; }, "frequency_Hz");
    with([](TrajectoryConfig& c) { c.frequency_Hz = 1e-6f; }, "frequency_Hz");  // < rate / 2^31
    with([](TrajectoryConfig& c) { c.sample_rate_Hz = -1.0f; }, "sample_rate_Hz");
    with([](TrajectoryConfig& c) { c.amplitude_um = -1.0f; }, "amplitude_um");
    with([](TrajectoryConfig& c) { c.amplitude_um = INFINITY; }, "amplitude_um");
    with([](TrajectoryConfig& c) { c.offset_um = NAN; }, "offset_um");
    with([](TrajectoryConfig& c) { c.start_phase_cycles = 1.0f; }, "start_phase_cycles");
    with([](TrajectoryConfig& c) { c.waveform = Waveform::kRaster; c.return_fraction = 0.0f; }, "return_fraction");
    with([](TrajectoryConfig& c) { c.waveform = Waveform::kSquare; c.duty = 1.0f; }, "duty");
    with([&](TrajectoryConfig& c) { c.waveform = Waveform::kTable; c.table = too_long; }, "table");
    with([&](TrajectoryConfig& c) { c.waveform = Waveform::kSteps; c.table = {}; }, "table");
    with([&](TrajectoryConfig& c) { c.waveform = Waveform::kTable; c.table = out_of_range; }, "table");
    for (const Case& k : cases) {
        const auto s = g.configure(k.c);
        ASSERT_FALSE(s.ok()) << k.field;
        EXPECT_STREQ(s.field, k.field);
    }
    EXPECT_FALSE(g.set_frequency(60000.0f).ok());
    // Nothing changed: the generator continues exactly like the reference.
    for (int i = 0; i < 500; ++i) ASSERT_EQ(g.step(), ref.step());

    // Q31: the trajectory must fit the signal's full scale.
    TrajectoryGenerator<Q31> q(SignalScale{10.0f});
    EXPECT_STREQ(q.configure(base(Waveform::kSine, 6.0f, 5.0f, 10.0f)).field, "amplitude_um");
    EXPECT_TRUE(q.configure(base(Waveform::kSine, 5.0f, 5.0f, 10.0f)).ok());
}

TEST(Trajectory, UnconfiguredOutputsZero) {
    TrajectoryGenerator<float> g;
    EXPECT_FALSE(g.configured());
    EXPECT_EQ(g.step(), 0.0f);
    EXPECT_FALSE(g.set_frequency(10.0f).ok());
    TrajectoryGenerator<Q31> q;
    EXPECT_EQ(q.step().raw(), 0);
}
