// The D fit (host/synth/d_fit): a known stable minimum-phase d(s) is
// recovered from samples of |d(jω)| alone, and bad input names the argument.
#include <cmath>
#include <stdexcept>
#include <vector>

#include <gtest/gtest.h>

#include "synth/d_fit.hpp"

using namespace piezoloop::design;

namespace {

double mag(const Zpk& d, double w) {
    const cplx s{0.0, w};
    cplx v = d.gain;
    for (const cplx& z : d.zeros) v *= s - z;
    for (const cplx& p : d.poles) v /= s - p;
    return std::abs(v);
}

std::vector<double> log_grid(double lo, double hi, int n) {
    std::vector<double> g;
    for (int i = 0; i < n; ++i) g.push_back(lo * std::pow(hi / lo, i / (n - 1.0)));
    return g;
}

}  // namespace

TEST(DFit, RecoversKnownScalingFromMagnitudes) {
    // Second order, corners spread over four decades, a lag then a lead.
    const Zpk truth{{{-10.0, 0.0}, {-1000.0, 0.0}}, {{-100.0, 0.0}, {-5000.0, 0.0}}, 3.0, 0.0};
    const std::vector<double> w = log_grid(0.1, 1e6, 120);
    std::vector<double> m;
    for (double x : w) m.push_back(mag(truth, x));
    const DFit f = fit_d_scaling(w, m, {}, 2);
    ASSERT_EQ(f.d.poles.size(), 2u);
    for (const cplx& p : f.d.poles) EXPECT_LT(p.real(), 0.0);
    for (const cplx& z : f.d.zeros) EXPECT_LT(z.real(), 0.0);
    EXPECT_LT(f.max_rel_error, 0.01);
    // Between and beyond the samples too.
    for (double x : log_grid(0.05, 2e6, 57)) EXPECT_NEAR(mag(f.d, x) / mag(truth, x), 1.0, 0.01) << x;
}

TEST(DFit, OrderZeroIsTheWeightedMeanInLog) {
    const DFit f = fit_d_scaling({1.0, 10.0}, {2.0, 8.0}, {1.0, 1.0}, 0);
    EXPECT_NEAR(f.d.gain, 4.0, 1e-12);
    EXPECT_TRUE(f.d.poles.empty());
}

TEST(DFit, HigherOrderNeverFitsWorse) {
    const std::vector<double> w = log_grid(1.0, 1e4, 60);
    std::vector<double> m;
    for (double x : w) m.push_back(1.0 + 0.5 * std::sin(std::log(x)));  // not rational: a compromise
    double prev = 1e300;
    for (int k = 0; k <= 3; ++k) {
        const DFit f = fit_d_scaling(w, m, {}, k);
        EXPECT_LE(f.rms_log_error, prev * (1.0 + 1e-9)) << k;
        prev = f.rms_log_error;
    }
}

TEST(DFit, BadInputNamesTheArgument) {
    auto msg = [](auto f) {
        try {
            f();
        } catch (const std::invalid_argument& e) {
            return std::string(e.what());
        }
        return std::string();
    };
    EXPECT_NE(msg([] { fit_d_scaling({1.0, 2.0}, {1.0}, {}, 0); }).find("same length"), std::string::npos);
    EXPECT_NE(msg([] { fit_d_scaling({1.0, 2.0}, {1.0, -1.0}, {}, 0); }).find("magnitude 1"), std::string::npos);
    EXPECT_NE(msg([] { fit_d_scaling({1.0, 2.0}, {1.0, 1.0}, {}, 2); }).find("parameters"), std::string::npos);
}
