// The static decoupling (host/measure/static_decoupling) against numpy
// (tests/golden/mimo_frf_ref.json): G0, its 1-norm condition
// (numpy.linalg.cond(G0, 1)), D = inv(G0) diag(G0) (numpy.linalg.inv) and the
// coupling of G(f) D on the lines; an exact static coupling removed to
// rounding; an ill-conditioned G0 refused.
#include <gtest/gtest.h>

#include <cmath>
#include <vector>

#include "measure/static_decoupling.hpp"
#include "mimo_reference.hpp"
#include "test_support.hpp"

using namespace piezoloop;

namespace {

Eigen::MatrixXd matrix(const nlohmann::json& j) {
    Eigen::MatrixXd m(static_cast<Eigen::Index>(j.size()), static_cast<Eigen::Index>(j[0].size()));
    for (Eigen::Index i = 0; i < m.rows(); ++i)
        for (Eigen::Index l = 0; l < m.cols(); ++l) m(i, l) = j[i][l].get<double>();
    return m;
}

}  // namespace

// G0 and D: a few roundings of well-conditioned (condition < 2) 2x2 and
// 3x3 inverses, 1e-12 relative. The coupling left after D at the low lines
// is ~-85 dB (the imaginary part and the O(w^2) change over 10-30 Hz): a
// ratio of ~5e-5 computed from differences of O(1) numbers, so 1e-11
// relative in the ratio, 1e-6 dB.
TEST(StaticDecoupling, MatchesNumpy) {
    for (int index : {0, 1}) {
        const test::MimoCase c = test::mimo_case(index);
        const measure::StaticDecoupling s = measure::static_decoupling(c.f_Hz, c.g);
        const Eigen::MatrixXd g0 = matrix(c.j["static_gain"]), d = matrix(c.j["output_matrix"]);
        EXPECT_LT((s.g0 - g0).cwiseAbs().maxCoeff(), 1e-12);
        EXPECT_NEAR(s.condition_1, c.j["condition_1"].get<double>(), 1e-12 * s.condition_1);
        EXPECT_LT((s.output_matrix - d).cwiseAbs().maxCoeff(), 1e-12);
        ASSERT_EQ(s.after.pairs.size(), c.j["after"].size());
        for (std::size_t q = 0; q < s.after.pairs.size(); ++q) {
            const auto& want = c.j["after"][q];
            EXPECT_NEAR(s.after.pairs[q].low_frequency_db, want["low_frequency_db"].get<double>(), 1e-6);
            EXPECT_NEAR(s.after.pairs[q].max_db, want["max_db"].get<double>(), 1e-9);
            EXPECT_DOUBLE_EQ(s.after.pairs[q].max_Hz, want["max_Hz"].get<double>());
            // Better than before at low frequency by > 50 dB.
            EXPECT_LT(s.after.pairs[q].low_frequency_db, -80.0);
        }
        // Each axis keeps its own static gain: G0 D = diag(G0).
        const Eigen::MatrixXd g0d = s.g0 * s.output_matrix;
        for (Eigen::Index j = 0; j < g0d.rows(); ++j) EXPECT_NEAR(g0d(j, j), s.g0(j, j), 1e-14);
    }
}

// An exact static coupling: D against numpy, and the coupling after it is
// rounding only (<= -100 dB; exactly 0 reads -inf).
TEST(StaticDecoupling, RemovesAnExactStaticCoupling) {
    const nlohmann::json st = test::load_golden("mimo_frf_ref")["static"];
    const Eigen::MatrixXd g0 = matrix(st["gain"]);
    const measure::StaticDecoupling s = measure::decouple_static_gain(g0);
    EXPECT_LT((s.output_matrix - matrix(st["output_matrix"])).cwiseAbs().maxCoeff(), 1e-14);
    EXPECT_NEAR(s.condition_1, st["condition_1"].get<double>(), 1e-12);
    for (Eigen::Index i = 0; i < 3; ++i)
        for (Eigen::Index j = 0; j < 3; ++j)
            if (i != j) {
                EXPECT_LE(s.static_after_db(i, j), -100.0) << i << j;
            }
    // The same gain at every line: the coupling after D is that too.
    std::vector<double> f{1.0, 2.0, 3.0, 4.0};
    std::vector<Eigen::MatrixXcd> g(4, g0.cast<std::complex<double>>());
    const measure::StaticDecoupling on_lines = measure::static_decoupling(f, g);
    for (const measure::CouplingPair& p : on_lines.after.pairs) EXPECT_LE(p.max_db, -100.0);
}

TEST(StaticDecoupling, RefusesAnIllConditionedGain) {
    const nlohmann::json ill = test::load_golden("mimo_frf_ref")["ill_conditioned"];
    const Eigen::MatrixXd g0 = matrix(ill["gain"]);
    EXPECT_NEAR(measure::condition_1(g0), ill["condition_1"].get<double>(), 1e-9 * 1999.0);
    const std::string why = test::error_of([&] { measure::decouple_static_gain(g0); });
    EXPECT_NE(why.find("G0: ill-conditioned, 1-norm condition 1999 > 1000"), std::string::npos) << why;
    // Accepted with a looser bound.
    EXPECT_EQ(test::error_of([&] { measure::decouple_static_gain(g0, 2000.0); }), "");
    Eigen::MatrixXd no_own = Eigen::MatrixXd::Identity(2, 2);
    no_own(1, 1) = 0.0;
    no_own(1, 0) = 0.5;
    EXPECT_NE(test::error_of([&] { measure::decouple_static_gain(no_own); }).find("G0: its diagonal element 22 is 0"),
              std::string::npos);
    EXPECT_TRUE(std::isinf(measure::condition_1(Eigen::MatrixXd::Ones(2, 2))));
}
