// The orthogonal multisines (host/measure/mimo_frf_plan): the lines of the
// single-axis rule, the periods against the documented formula written out
// by numpy (tests/golden/mimo_frf_ref.json), one peak for every input and
// block, and the input matrix per line orthogonal (condition 1).
#include <gtest/gtest.h>

#include <cmath>
#include <complex>
#include <numbers>
#include <vector>

#include <Eigen/Dense>

#include "measure/mimo_frf_plan.hpp"
#include "mimo_reference.hpp"
#include "test_support.hpp"

using namespace piezoloop;

TEST(MimoFrfPlan, LinesAreTheSingleAxisRule) {
    for (int index : {0, 1}) {
        const test::MimoCase c = test::mimo_case(index);
        const measure::MimoFrfPlan p = measure::plan_mimo_frf(test::mimo_request(c, 3, 2));
        EXPECT_EQ(p.inputs, c.n);
        EXPECT_EQ(p.layout.period_samples, c.j["period_samples"].get<uint32_t>());
        EXPECT_EQ(p.layout.first_bin, c.j["first_bin"].get<uint32_t>());
        EXPECT_EQ(p.layout.last_bin, c.j["last_bin"].get<uint32_t>());
        ASSERT_EQ(p.frequency_Hz.size(), c.f_Hz.size());
        for (std::size_t k = 0; k < c.f_Hz.size(); ++k) EXPECT_DOUBLE_EQ(p.frequency_Hz[k], c.f_Hz[k]);
        EXPECT_EQ(p.block_samples, 5u * p.layout.period_samples);
        EXPECT_EQ(p.measured_start, 2u * p.layout.period_samples);
    }
}

// numpy's direct sum of cosines against the inverse DFT: both are exact
// formulas, so they agree to rounding (1e-12 V at a peak of 1 V).
TEST(MimoFrfPlan, PeriodsMatchTheFormula) {
    const nlohmann::json m = test::load_golden("mimo_frf_ref")["multisine"];
    measure::MimoFrfRequest r;
    r.inputs = m["inputs"].get<int>();
    r.rate_Hz = m["rate_Hz"].get<double>();
    r.from_Hz = m["from_Hz"].get<double>();
    r.to_Hz = m["to_Hz"].get<double>();
    r.amplitude_V = m["amplitude_V"].get<double>();
    const measure::MimoFrfPlan p = measure::plan_mimo_frf(r);
    EXPECT_NEAR(p.line_amplitude_V, m["line_amplitude_V"].get<double>(), 1e-12);
    for (int b = 0; b < r.inputs; ++b)
        for (int l = 0; l < r.inputs; ++l) {
            const std::vector<double> x = measure::mimo_period(p, b, l);
            const std::vector<double> want = m["period"][b][l].get<std::vector<double>>();
            ASSERT_EQ(x.size(), want.size());
            for (std::size_t t = 0; t < x.size(); ++t) EXPECT_NEAR(x[t], want[t], 1e-12) << b << " " << l << " " << t;
        }
}

TEST(MimoFrfPlan, OnePeakForAllAndBiasAdded) {
    measure::MimoFrfRequest r = test::mimo_request(test::mimo_case(1), 2, 1);
    r.amplitude_V = 2.5;
    r.bias_V = {10.0, -3.0, 0.5};
    const measure::MimoFrfPlan p = measure::plan_mimo_frf(r);
    double peak = 0.0;
    for (int b = 0; b < 3; ++b) {
        const std::vector<std::vector<double>> block = measure::mimo_block(p, b);
        ASSERT_EQ(block.size(), 3u);
        for (int l = 0; l < 3; ++l) {
            ASSERT_EQ(block[l].size(), p.block_samples);
            double mean = 0.0;
            for (std::size_t t = 0; t < block[l].size(); ++t) {
                peak = std::max(peak, std::fabs(block[l][t] - r.bias_V[l]));
                mean += block[l][t];
                // The period repeats exactly.
                if (t >= p.layout.period_samples) {
                    ASSERT_EQ(block[l][t], block[l][t - p.layout.period_samples]);
                }
            }
            EXPECT_NEAR(mean / static_cast<double>(block[l].size()), r.bias_V[l], 1e-12);
        }
    }
    EXPECT_NEAR(peak, 2.5, 1e-12);
}

// The DFT of the planned periods at every line: U = (a N / 2) e^{j phi} T,
// T the DFT matrix, so all singular values are equal (condition 1 to
// rounding) and each element has the line amplitude a.
TEST(MimoFrfPlan, InputMatrixIsOrthogonal) {
    for (int n : {1, 2, 3}) {
        measure::MimoFrfRequest r = test::mimo_request(test::mimo_case(1), 1, 0);
        r.inputs = n;
        const measure::MimoFrfPlan p = measure::plan_mimo_frf(r);
        const std::size_t N = p.layout.period_samples;
        std::vector<std::vector<std::vector<double>>> x(n);
        for (int b = 0; b < n; ++b)
            for (int l = 0; l < n; ++l) x[b].push_back(measure::mimo_period(p, b, l));
        for (std::size_t j = 0; j < p.frequency_Hz.size(); j += 7) {
            const std::size_t k = p.layout.first_bin + j;
            Eigen::MatrixXcd u(n, n);
            for (int b = 0; b < n; ++b)
                for (int l = 0; l < n; ++l) {
                    std::complex<double> s = 0.0;
                    for (std::size_t t = 0; t < N; ++t)
                        s += x[b][l][t] * std::polar(1.0, -2.0 * std::numbers::pi * static_cast<double>(k * t % N) /
                                                              static_cast<double>(N));
                    u(l, b) = s * (2.0 / static_cast<double>(N));
                    EXPECT_NEAR(std::abs(u(l, b)), p.line_amplitude_V, 1e-12);
                }
            const Eigen::JacobiSVD<Eigen::MatrixXcd> svd(u);
            EXPECT_NEAR(svd.singularValues()(0) / svd.singularValues()(n - 1), 1.0, 1e-9) << n << " " << k;
        }
    }
}

TEST(MimoFrfPlan, RefusesNamingTheField) {
    const measure::MimoFrfRequest ok = test::mimo_request(test::mimo_case(0), 10, 1);
    auto refusal = [&](auto change) {
        measure::MimoFrfRequest r = ok;
        change(r);
        return test::error_of([&] { measure::plan_mimo_frf(r); });
    };
    EXPECT_EQ(refusal([](auto&) {}), "");
    EXPECT_NE(refusal([](auto& r) { r.inputs = 4; }).find("inputs: must be 1, 2 or 3"), std::string::npos);
    EXPECT_NE(refusal([](auto& r) { r.to_Hz = 5000.0; }).find("to_Hz: must be below the Nyquist"), std::string::npos);
    EXPECT_NE(refusal([](auto& r) { r.from_Hz = 3000.0; }).find("from_Hz: must be below to_Hz"), std::string::npos);
    EXPECT_NE(refusal([](auto& r) { r.from_Hz = 1e-3; }).find("from_Hz: must be >="), std::string::npos);
    EXPECT_NE(refusal([](auto& r) { r.amplitude_V = 0.0; }).find("amplitude_V: must be in (0, 1e6]"), std::string::npos);
    EXPECT_NE(refusal([](auto& r) { r.bias_V = {1.0}; }).find("bias_V: must have one entry per input"), std::string::npos);
    EXPECT_NE(refusal([](auto& r) { r.periods = 0; }).find("periods: must be in [1, 10000]"), std::string::npos);
    EXPECT_NE(refusal([](auto& r) { r.transient_periods = -1; }).find("transient_periods: must be in [0, 100]"),
              std::string::npos);
    EXPECT_NE(refusal([](auto& r) { r.periods = 2000; }).find("exceeds the longest record"), std::string::npos);
    EXPECT_NE(refusal([](auto& r) { r.from_Hz = 4000.0; r.to_Hz = 4500.0; }).find("to_Hz: no DFT line"),
              std::string::npos);
}
