// Mains pickup (common/piezoloop/mains_pickup.hpp) against the analytic sum
// of sinusoids at the mains frequency and its harmonics.
#include <gtest/gtest.h>

#include <cmath>
#include <complex>
#include <limits>
#include <numbers>
#include <vector>

#include "piezoloop/mains_pickup.hpp"

using namespace piezoloop;

TEST(MainsPickup, IsTheSumOfHarmonicSinesAtTheMainsFrequency) {
    // 50 Hz with 3, 2 and 1 nm at 50, 100 and 150 Hz, 20 kHz, 1 s.
    const double rate = 20000.0, f = 50.0;
    MainsConfig c{};
    c.frequency_Hz = 50.0f;
    c.count = 3;
    c.amplitudes_um = {0.003f, 0.002f, 0.001f};
    MainsPickup m;
    ASSERT_TRUE(m.configure(c, static_cast<float>(rate)).ok());
    // round(50 / 20000 * 2^32) = round(10737418.24).
    EXPECT_EQ(m.phase_increment(), 10737418u);
    const double amp_sum = 0.006;
    const int n_total = 20000;
    double worst = 0.0;
    std::vector<double> y(n_total);
    for (int n = 0; n < n_total; ++n) {
        y[static_cast<size_t>(n)] = m.next_um();
        const double t = n / rate;
        double exact = 0.0;
        for (int k = 1; k <= 3; ++k)
            exact += c.amplitudes_um[static_cast<size_t>(k - 1)] * std::sin(2.0 * std::numbers::pi * k * f * t);
        worst = std::max(worst, std::fabs(y[static_cast<size_t>(n)] - exact));
    }
    // The sine table is within 2.95e-7 of each harmonic's amplitude; the
    // phase increment is 50 Hz within rate / 2^33 = 2.3e-6 Hz, so harmonic k
    // is at most 2 pi k 2.3e-6 t rad off after t = 1 s; float rounding of
    // the sum adds a few ulp of 6e-3 (~5e-10 each).
    const double phase = 2.0 * std::numbers::pi * 2.33e-6 * 1.0;
    const double bound = amp_sum * 2.95e-7 + (0.003 * 1 + 0.002 * 2 + 0.001 * 3) * phase + 4e-9;
    EXPECT_LT(worst, bound);
    // Amplitudes by a DFT over the 50 whole periods of 1 s: each harmonic's
    // a_k, nothing at 200 Hz or at DC.
    for (int k = 0; k <= 4; ++k) {
        std::complex<double> acc = 0.0;
        for (int n = 0; n < n_total; ++n)
            acc += y[static_cast<size_t>(n)] * std::polar(1.0, -2.0 * std::numbers::pi * k * f * n / rate);
        const double a = (k == 0 ? 1.0 : 2.0) * std::abs(acc) / n_total;
        const double expect = k >= 1 && k <= 3 ? c.amplitudes_um[static_cast<size_t>(k - 1)] : 0.0;
        EXPECT_NEAR(a, expect, 1e-8) << "harmonic " << k;
    }
    // Reset: phase 0 again.
    m.reset();
    EXPECT_EQ(m.next_um(), static_cast<float>(y[0]));
    EXPECT_EQ(m.next_um(), static_cast<float>(y[1]));
}

TEST(MainsPickup, OffIsZeroAndBadValuesAreRefusedByName) {
    MainsPickup off;
    ASSERT_TRUE(off.configure({}, 20000.0f).ok());
    EXPECT_FALSE(off.enabled());
    EXPECT_EQ(off.next_um(), 0.0f);
    const float nan = std::numeric_limits<float>::quiet_NaN();
    struct Bad {
        float f;
        int count;
        float a1;
        const char* field;
        int index;
    };
    const Bad bad[] = {
        {50.0f, 9, 0.001f, "count", -1},
        {50.0f, -1, 0.001f, "count", -1},
        {50.0f, 2, -0.001f, "amplitudes_um", 1},
        {50.0f, 2, nan, "amplitudes_um", 1},
        {50.0f, 2, 2000.0f, "amplitudes_um", 1},
        {0.0f, 2, 0.001f, "frequency_Hz", -1},
        {nan, 2, 0.001f, "frequency_Hz", -1},
        {5000.0f, 2, 0.001f, "frequency_Hz", -1},  // 2nd harmonic at Nyquist of 20 kHz
    };
    for (const Bad& b : bad) {
        MainsConfig c{};
        c.frequency_Hz = b.f;
        c.count = b.count;
        c.amplitudes_um[0] = 0.002f;
        c.amplitudes_um[1] = b.a1;
        MainsPickup m;
        const Status s = m.configure(c, 20000.0f);
        ASSERT_FALSE(s.ok()) << b.field;
        EXPECT_STREQ(s.field, b.field);
        EXPECT_EQ(s.index, b.index);
    }
}
