// The coupling figures (host/measure/coupling) on scipy's exact response of
// the 2x2 and 3x3 systems of tests/golden/mimo_frf_ref.json, against numpy's
// figures from the same response (1e-9 dB: both are a ratio of magnitudes
// in double).
#include <gtest/gtest.h>

#include <cmath>
#include <vector>

#include "measure/coupling.hpp"
#include "mimo_reference.hpp"
#include "test_support.hpp"

using namespace piezoloop;

TEST(Coupling, MatchesNumpy) {
    for (int index : {0, 1}) {
        const test::MimoCase c = test::mimo_case(index);
        const measure::Coupling k = measure::coupling(c.f_Hz, c.g);
        EXPECT_EQ(k.low_lines, (std::vector<int>{0, 1, 2}));
        ASSERT_EQ(k.pairs.size(), c.j["coupling"].size());
        for (std::size_t q = 0; q < k.pairs.size(); ++q) {
            const auto& want = c.j["coupling"][q];
            const measure::CouplingPair& got = k.pairs[q];
            EXPECT_EQ(got.output, want["output"].get<int>());
            EXPECT_EQ(got.input, want["input"].get<int>());
            EXPECT_NEAR(got.low_frequency_db, want["low_frequency_db"].get<double>(), 1e-9);
            EXPECT_NEAR(got.max_db, want["max_db"].get<double>(), 1e-9);
            EXPECT_DOUBLE_EQ(got.max_Hz, want["max_Hz"].get<double>());
            const std::vector<double> per_line = want["coupling_db"].get<std::vector<double>>();
            ASSERT_EQ(got.coupling_db.size(), per_line.size());
            for (std::size_t l = 0; l < per_line.size(); ++l) EXPECT_NEAR(got.coupling_db[l], per_line[l], 1e-9);
        }
    }
}

// The low-frequency lines: those at or below below_Hz; the figure is
// 20 log10 of the mean ratio over them.
TEST(Coupling, BelowAFrequency) {
    const test::MimoCase c = test::mimo_case(0);
    const measure::Coupling k = measure::coupling(c.f_Hz, c.g, 50.0);
    EXPECT_EQ(k.low_lines, (std::vector<int>{0, 1, 2, 3, 4}));
    double mean = 0.0;
    for (int l = 0; l < 5; ++l) mean += std::abs(c.g[l](1, 0)) / std::abs(c.g[l](0, 0));
    EXPECT_NEAR(k.pairs[1].low_frequency_db, 20.0 * std::log10(mean / 5.0), 1e-12);
    // The systems' DC couplings are 3 % and 5 % of the column's own gain: at 10-50 Hz, far below
    // the modes (>= 400 Hz), the figures are within 0.2 dB of them.
    EXPECT_NEAR(k.pairs[0].low_frequency_db, 20.0 * std::log10(0.03), 0.2);
    EXPECT_NEAR(k.pairs[1].low_frequency_db, 20.0 * std::log10(0.05), 0.2);
}

TEST(Coupling, Refusals) {
    const test::MimoCase c = test::mimo_case(0);
    EXPECT_NE(test::error_of([&] { measure::coupling(c.f_Hz, c.g, 5.0); }).find("below_Hz: must be >= the lowest line, 10 Hz"),
              std::string::npos);
    std::vector<Eigen::MatrixXcd> wide(c.g.size(), Eigen::MatrixXcd::Ones(2, 3));
    EXPECT_NE(test::error_of([&] { measure::coupling(c.f_Hz, wide); }).find("square"), std::string::npos);
    std::vector<Eigen::MatrixXcd> still = c.g;
    still[7](1, 1) = 0.0;
    EXPECT_NE(test::error_of([&] { measure::coupling(c.f_Hz, still); }).find("G22 is 0 at 80 Hz"), std::string::npos);
    EXPECT_NE(test::error_of([&] { measure::coupling({10.0}, c.g); }).find("one matrix per line"), std::string::npos);
}
