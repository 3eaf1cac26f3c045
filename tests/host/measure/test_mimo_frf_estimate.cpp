// The n x n estimate (host/measure/mimo_frf_estimate) on the orthogonal
// multisines through the 2x2 and 3x3 systems of
// tests/golden/mimo_frf_ref.json, simulated from rest by their difference
// equations, against scipy's exact response per line (freqz).
#include <gtest/gtest.h>

#include <cmath>
#include <random>
#include <vector>

#include "measure/mimo_frf_estimate.hpp"
#include "mimo_reference.hpp"
#include "test_support.hpp"

using namespace piezoloop;

namespace {

using Records = std::vector<std::vector<std::vector<double>>>;

Records planned_inputs(const measure::MimoFrfPlan& p) {
    Records u;
    for (int b = 0; b < p.inputs; ++b) u.push_back(measure::mimo_block(p, b));
    return u;
}

// The largest |G - G_exact| / |G_exact| over the lines and elements.
double worst_relative_error(const measure::MimoFrfEstimate& e, const test::MimoCase& c) {
    double worst = 0.0;
    for (std::size_t k = 0; k < c.g.size(); ++k)
        for (int i = 0; i < c.n; ++i)
            for (int l = 0; l < c.n; ++l)
                worst = std::max(worst, std::abs(e.response[k](i, l) - c.g[k](i, l)) / std::abs(c.g[k](i, l)));
    return worst;
}

}  // namespace

// Without noise, after D discarded periods with r^(D N) <= 1e-16 (r the
// slowest pole's radius, 0.988: D = 4 at N = 1000), the record is periodic to
// rounding and the DFT of a period is G U exactly at every excited bin: the
// estimate is scipy's G to 1e-9 relative (the smallest elements are ~1e-4 of
// the largest; rounding of the DFTs is ~1e-16 of the largest).
TEST(MimoFrfEstimate, ExactWithoutNoise) {
    for (int index : {0, 1}) {
        const test::MimoCase c = test::mimo_case(index);
        const int d = test::transient_periods_for(c);
        EXPECT_EQ(d, 4);
        const measure::MimoFrfPlan p = measure::plan_mimo_frf(test::mimo_request(c, 2, d));
        const Records u = planned_inputs(p);
        const measure::MimoFrfEstimate e = measure::estimate_mimo_frf(p, u, test::mimo_simulate(c, u));
        ASSERT_EQ(e.response.size(), c.g.size());
        EXPECT_EQ(e.inputs, c.n);
        EXPECT_EQ(e.outputs, c.n);
        EXPECT_LT(worst_relative_error(e, c), 1e-9) << c.j["name"];
        for (std::size_t k = 0; k < c.g.size(); ++k) {
            EXPECT_DOUBLE_EQ(e.frequency_Hz[k], c.f_Hz[k]);
            EXPECT_NEAR(e.input_condition[k], 1.0, 1e-9);
            EXPECT_LT(e.std_dev[k].maxCoeff(), 1e-9 * e.response[k].cwiseAbs().maxCoeff());
        }
    }
}

// Without discarding the transient the estimate is off: the test above
// depends on D.
TEST(MimoFrfEstimate, TransientBiasesWithoutDiscardedPeriods) {
    const test::MimoCase c = test::mimo_case(0);
    const measure::MimoFrfPlan p = measure::plan_mimo_frf(test::mimo_request(c, 2, 0));
    const Records u = planned_inputs(p);
    EXPECT_GT(worst_relative_error(measure::estimate_mimo_frf(p, u, test::mimo_simulate(c, u)), c), 1e-4);
}

// A 16-bit DAC's command (steps of 2^-15 V): the estimate from the recorded
// (quantised) u is still exact, the one from the planned u is not.
TEST(MimoFrfEstimate, UsesTheMeasuredInputs) {
    const test::MimoCase c = test::mimo_case(1);
    const measure::MimoFrfPlan p = measure::plan_mimo_frf(test::mimo_request(c, 2, test::transient_periods_for(c)));
    const Records planned = planned_inputs(p);
    Records dac = planned;
    for (auto& block : dac)
        for (auto& ch : block)
            for (double& x : ch) x = std::round(x * 32768.0) / 32768.0;
    const Records y = test::mimo_simulate(c, dac);
    EXPECT_LT(worst_relative_error(measure::estimate_mimo_frf(p, dac, y), c), 1e-9);
    EXPECT_GT(worst_relative_error(measure::estimate_mimo_frf(p, planned, y), c), 1e-5);
}

// White noise on every output (seeded): the errors against the exact G lie
// within 3 standard deviations for >= 99 % of the elements (a complex
// Gaussian error exceeds 3 sigma with probability e^-9; with sigma estimated
// from P = 10 periods, (1 + 9/9)^-9 = 0.2 %), and the standard deviation
// estimate matches the error's RMS over the 1800 elements within 1.5x.
TEST(MimoFrfEstimate, StandardDeviationMatchesTheErrors) {
    const test::MimoCase c = test::mimo_case(1);
    const measure::MimoFrfPlan p = measure::plan_mimo_frf(test::mimo_request(c, 10, test::transient_periods_for(c)));
    const Records u = planned_inputs(p);
    Records y = test::mimo_simulate(c, u);
    std::mt19937_64 rng(20261127);
    std::normal_distribution<double> noise(0.0, 1e-3);
    for (auto& block : y)
        for (auto& ch : block)
            for (double& x : ch) x += noise(rng);
    const measure::MimoFrfEstimate e = measure::estimate_mimo_frf(p, u, y);
    int within = 0, total = 0;
    double err2 = 0.0, var = 0.0;
    for (std::size_t k = 0; k < c.g.size(); ++k)
        for (int i = 0; i < c.n; ++i)
            for (int l = 0; l < c.n; ++l) {
                const double err = std::abs(e.response[k](i, l) - c.g[k](i, l)), sd = e.std_dev[k](i, l);
                within += err <= 3.0 * sd ? 1 : 0;
                ++total;
                err2 += err * err;
                var += sd * sd;
                EXPECT_NEAR(e.snr_db[k](i, l), 20.0 * std::log10(std::abs(e.response[k](i, l)) / sd), 1e-9);
            }
    EXPECT_EQ(total, 1800);
    EXPECT_GE(within, 0.99 * total) << within << " of " << total;
    const double ratio = std::sqrt(err2 / var);
    RecordProperty("within_3_std", within);
    RecordProperty("error_rms_over_std_rms", std::to_string(ratio));
    EXPECT_GT(ratio, 1.0 / 1.5);
    EXPECT_LT(ratio, 1.5);
    // And the analytic value: a period's DFT of white noise in peak units
    // (2 X / N) has E|.|^2 = 4 sigma^2 / N, its mean over P periods 1/P of
    // it; G's error E U^-1 with U^-1 = e^{-j phi} T^H / (n a) sums n such
    // terms / (n a)^2: std G = 2 sigma / (a sqrt(N P n)) for every element.
    const double expected = 2e-3 / (p.line_amplitude_V * std::sqrt(static_cast<double>(p.layout.period_samples) * 10.0 * c.n));
    EXPECT_NEAR(std::sqrt(var / total), expected, 0.1 * expected);
}

TEST(MimoFrfEstimate, OnePeriodHasNoStandardDeviation) {
    const test::MimoCase c = test::mimo_case(0);
    const measure::MimoFrfPlan p = measure::plan_mimo_frf(test::mimo_request(c, 1, 4));
    const Records u = planned_inputs(p);
    const measure::MimoFrfEstimate e = measure::estimate_mimo_frf(p, u, test::mimo_simulate(c, u));
    EXPECT_TRUE(std::isnan(e.std_dev[0](0, 1)));
    EXPECT_LT(worst_relative_error(e, c), 1e-9);
}

TEST(MimoFrfEstimate, RefusesRecordsThatDoNotFitThePlan) {
    const test::MimoCase c = test::mimo_case(0);
    const measure::MimoFrfPlan p = measure::plan_mimo_frf(test::mimo_request(c, 2, 1));
    const Records u = planned_inputs(p);
    const Records y = test::mimo_simulate(c, u);
    EXPECT_NE(test::error_of([&] { measure::estimate_mimo_frf(p, Records(u.begin(), u.begin() + 1), y); })
                  .find("u: must hold the plan's 2 blocks"),
              std::string::npos);
    Records short_y = y;
    short_y[1][0].pop_back();
    EXPECT_NE(test::error_of([&] { measure::estimate_mimo_frf(p, u, short_y); }).find("y[1][0]: must hold the block's"),
              std::string::npos);
    Records dead = u;
    for (auto& block : dead) block[1].assign(block[1].size(), 0.0);
    EXPECT_NE(test::error_of([&] { measure::estimate_mimo_frf(p, dead, y); }).find("u: the measured input matrix is singular"),
              std::string::npos);
}
