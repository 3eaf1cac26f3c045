// The multisine estimate (host/measure/frf_estimate) on records made by the
// core's excitation through a known periodic filter: exact response without
// noise, a variance that matches the noise put in.
#include <gtest/gtest.h>

#include <cmath>
#include <complex>
#include <memory>
#include <numbers>
#include <random>
#include <vector>

#include "measure/frf_estimate.hpp"
#include "piezoloop/excitation.hpp"

using namespace piezoloop;

namespace {

constexpr uint32_t N = 500, k1 = 2, k2 = 200;

// y = h * u, circular over the period (a steady-state periodic response),
// h = 0.5 delta[n - 1] + 0.25 delta[n - 2]: H(k) = e^{-j th} (0.5 + 0.25 e^{-j th}).
std::vector<double> filter(const std::vector<double>& u) {
    std::vector<double> y(u.size());
    for (size_t n = 0; n < u.size(); ++n) {
        const size_t p = n / N * N, i = n % N;
        y[n] = 0.5 * u[p + (i + N - 1) % N] + 0.25 * u[p + (i + N - 2) % N];
    }
    return y;
}

std::vector<double> record(int periods) {
    auto g = std::make_unique<ExcitationGenerator<float, 1024>>();
    ExcitationConfig c;
    c.period_samples = N;
    c.first_bin = k1;
    c.last_bin = k2;
    c.amplitude = 1.0f;
    c.sample_rate_Hz = 1000.0f;
    EXPECT_TRUE(g->configure(c).ok());
    std::vector<double> u;
    for (uint32_t i = 0; i < N * static_cast<uint32_t>(periods); ++i) u.push_back(g->step());
    return u;
}

}  // namespace

TEST(FrfEstimate, ExactWithoutNoise) {
    const std::vector<double> u = record(3), y = filter(u);
    const measure::FrfEstimate e = measure::estimate_multisine(u, y, {1000.0, N, k1, k2});
    ASSERT_EQ(e.response.size(), k2 - k1 + 1);
    for (size_t j = 0; j < e.response.size(); ++j) {
        const double th = 2 * std::numbers::pi * (k1 + j) / N;
        const std::complex<double> h = std::polar(1.0, -th) * (0.5 + 0.25 * std::polar(1.0, -th));
        EXPECT_LT(std::abs(e.response[j] - h), 1e-9) << j;
        EXPECT_DOUBLE_EQ(e.frequency_Hz[j], (k1 + j) * 1000.0 / N);
        EXPECT_LT(e.std_db[j], 1e-6);
    }
}

TEST(FrfEstimate, VarianceMatchesTheNoise) {
    // White noise of sigma on y: a DFT bin has variance N sigma^2, the peak
    // scaling 2 / N makes it 4 sigma^2 / N per period, / P for the mean, so
    // sigma_G = 2 sigma / sqrt(N P) / |Ubar|.
    const int P = 40;
    const double sigma = 0.01;
    const std::vector<double> u = record(P);
    std::vector<double> y = filter(u);
    std::mt19937_64 rng(7);
    std::normal_distribution<double> noise(0.0, sigma);
    for (double& v : y) v += noise(rng);
    const measure::FrfEstimate e = measure::estimate_multisine(u, y, {1000.0, N, k1, k2});
    double ratio_sum = 0.0;
    for (size_t j = 0; j < e.response.size(); ++j) {
        const double expected = 2.0 * sigma / std::sqrt(double{N} * P) / std::abs(e.u_line[j]);
        ratio_sum += std::sqrt(e.var[j]) / expected;
    }
    // The mean over 199 lines of a chi-like ratio with 39 degrees of freedom.
    EXPECT_NEAR(ratio_sum / e.response.size(), 1.0, 0.05);
    EXPECT_THROW((void)measure::estimate_multisine(u, std::vector<double>(u.size() - 1), {1000.0, N, k1, k2}),
                 std::invalid_argument);
}

TEST(FrfEstimate, H1OfAPrbsThroughAFilter) {
    // PRBS (order 12) through y = 0.5 u[n-1] + 0.25 u[n-2] (not circular):
    // H1 within 2 % (the window's bias for a 2-sample delay in a 512-sample
    // segment), coherence near 1 without noise, lower with it.
    ExcitationConfig c;
    c.signal = ExcitationSignal::kPrbs;
    c.prbs_order = 12;
    c.amplitude = 1.0f;
    c.sample_rate_Hz = 1000.0f;
    ExcitationGenerator<float, 4> g;
    ASSERT_TRUE(g.configure(c).ok());
    std::vector<double> u(4 * 4095), y(u.size()), yn(u.size());
    for (double& v : u) v = g.step();
    std::mt19937_64 rng(3);
    std::normal_distribution<double> noise(0.0, 0.3);
    for (size_t n = 0; n < u.size(); ++n) {
        y[n] = (n >= 1 ? 0.5 * u[n - 1] : 0.0) + (n >= 2 ? 0.25 * u[n - 2] : 0.0);
        yn[n] = y[n] + noise(rng);
    }
    const measure::WelchEstimate e = measure::estimate_h1(u, y, 1000.0, 512, 5.0, 400.0);
    ASSERT_FALSE(e.response.empty());
    EXPECT_GT(e.segments, 60);
    for (size_t j = 0; j < e.response.size(); ++j) {
        const double th = 2 * std::numbers::pi * e.frequency_Hz[j] / 1000.0;
        const std::complex<double> h = std::polar(1.0, -th) * (0.5 + 0.25 * std::polar(1.0, -th));
        EXPECT_LT(std::abs(e.response[j] - h) / std::abs(h), 0.02) << e.frequency_Hz[j];
        EXPECT_GT(e.coherence[j], 0.99) << e.frequency_Hz[j];
    }
    const measure::WelchEstimate en = measure::estimate_h1(u, yn, 1000.0, 512, 5.0, 400.0);
    double coh = 0.0;
    for (const double x : en.coherence) coh += x;
    EXPECT_LT(coh / en.coherence.size(), 0.95);  // |H| ~ 0.5, noise 0.3 rms: SNR ~ 4 per sample
}

namespace {

// The record of `periods` periods through the filter with white noise of
// sigma on y, plus a decaying ring at f0_Hz from the record's start (a
// lightly damped mode excited by how the run began) of amplitude a0 and
// time constant tau_s.
std::vector<double> noisy(const std::vector<double>& u, double sigma, unsigned seed, double a0 = 0.0,
                          double f0_Hz = 0.0, double tau_s = 1.0) {
    std::vector<double> y = filter(u);
    std::mt19937_64 rng(seed);
    std::normal_distribution<double> noise(0.0, sigma);
    for (size_t n = 0; n < y.size(); ++n) {
        const double t = static_cast<double>(n) / 1000.0;
        y[n] += noise(rng) + a0 * std::exp(-t / tau_s) * std::sin(2.0 * std::numbers::pi * f0_Hz * t);
    }
    return y;
}

}  // namespace

TEST(FrfEstimate, TransientCheckFlagsARingingStartAndNothingElse) {
    // Without a transient no line is flagged, over 199 lines, with 4 and 10
    // periods and ten noise seeds each (z^2 > 25 has a probability below
    // 1e-6 per line: 4000 line checks flag none unless the test is wrong).
    for (const int P : {4, 10}) {
        const std::vector<double> u = record(P);
        for (unsigned seed = 1; seed <= 10; ++seed) {
            const measure::FrfEstimate e = measure::estimate_multisine(u, noisy(u, 0.01, seed), {1000.0, N, k1, k2});
            ASSERT_EQ(e.half_change_rel.size(), e.response.size());
            EXPECT_TRUE(e.transient_lines.empty()) << P << " periods, seed " << seed << ": " << e.transient_lines.size();
        }
    }
    // Nor without noise: the halves are the same to rounding.
    {
        const std::vector<double> u = record(4);
        EXPECT_TRUE(measure::estimate_multisine(u, filter(u), {1000.0, N, k1, k2}).transient_lines.empty());
    }
    // A ring at 100 Hz (line 50) decaying with tau 0.2 s (ζ 0.008) from the
    // start, 0.1 at first: in the first half of 4 periods (2 s) it is still
    // 0.1 e^-5 ... 0.1, in the second e^-10 of it. Flagged at 100 Hz, and
    // only near it (the ring's spectrum falls off as 1 / |f - f0|).
    const std::vector<double> u = record(4);
    const measure::FrfEstimate e = measure::estimate_multisine(u, noisy(u, 0.01, 3, 0.1, 100.0, 0.2), {1000.0, N, k1, k2});
    ASSERT_FALSE(e.transient_lines.empty());
    bool at_f0 = false;
    for (const size_t j : e.transient_lines) {
        at_f0 = at_f0 || e.frequency_Hz[j] == 100.0;
        EXPECT_NEAR(e.frequency_Hz[j], 100.0, 20.0);
    }
    EXPECT_TRUE(at_f0);
    // Fewer than 4 periods: no check.
    const std::vector<double> u3 = record(3);
    EXPECT_TRUE(measure::estimate_multisine(u3, noisy(u3, 0.01, 1, 0.1, 100.0, 0.2), {1000.0, N, k1, k2})
                    .half_change_rel.empty());
}
