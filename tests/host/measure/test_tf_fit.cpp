// identify tf's fit (host/measure/tf_fit) on responses of known models: the
// coefficients come back to 1e-6 from exact data, unstable poles are
// reflected, and orders the data cannot support are refused.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <complex>
#include <stdexcept>
#include <string>
#include <vector>

#include "lti/freqresp.hpp"
#include "lti/lti_convert.hpp"
#include "measure/tf_fit.hpp"

using namespace piezoloop;
using design::cplx;

namespace {

constexpr double kFs = 10000.0, kTs = 1.0 / kFs;

std::vector<double> lines(int n, double lo, double hi) {
    std::vector<double> f;
    for (int i = 0; i < n; ++i) f.push_back(lo + (hi - lo) * i / (n - 1));
    return f;
}

// Discrete z^-K B(q)/A(q) with A from its poles (descending powers of z).
design::Tf discrete_model(const std::vector<cplx>& poles, const std::vector<double>& b, int K) {
    design::Tf tf;
    tf.den = design::poly_from_roots(poles);
    const int N = static_cast<int>(poles.size()), M = static_cast<int>(b.size()) - 1;
    const int L = std::max(N, M + K);
    tf.den.resize(static_cast<size_t>(L + 1), 0.0);
    tf.num.assign(static_cast<size_t>(L + 1), 0.0);
    for (int k = 0; k <= M; ++k) tf.num[static_cast<size_t>(K + k)] = b[static_cast<size_t>(k)];
    tf.ts = kTs;
    return tf;
}

std::vector<cplx> response(const design::Tf& tf, const std::vector<double>& f) {
    std::vector<cplx> g;
    for (const double x : f) g.push_back(design::evaluate(tf, design::frequency_point(2 * M_PI * x, tf.ts)));
    return g;
}

cplx pole_of(double f_Hz, double zeta) {
    const double w = 2 * M_PI * f_Hz;
    return std::exp(cplx(-zeta * w, w * std::sqrt(1 - zeta * zeta)) * kTs);
}

}  // namespace

TEST(TfFit, RecoversAKnownDiscreteModelFromExactData) {
    const cplx p = pole_of(1000.0, 0.05);
    const std::vector<cplx> poles = {p, std::conj(p), std::exp(-2 * M_PI * 300.0 * kTs)};
    const std::vector<double> b = {0.02, 0.03, -0.01};
    const design::Tf truth = discrete_model(poles, b, 2);
    const std::vector<double> f = lines(200, 10.0, 4000.0);
    measure::TfFitOptions o;
    o.poles = 3;
    o.zeros = 2;
    o.delay_samples = 2;
    o.ts = kTs;
    const measure::TfFit fit = measure::fit_tf(f, response(truth, f), {}, o);
    ASSERT_EQ(fit.model.den.size(), truth.den.size());
    for (size_t i = 0; i < truth.den.size(); ++i) EXPECT_NEAR(fit.model.den[i], truth.den[i], 1e-6) << i;
    // num: the fit strips the leading zeros of the delay.
    std::vector<double> tn = truth.num;
    while (tn.front() == 0.0) tn.erase(tn.begin());
    ASSERT_EQ(fit.model.num.size(), tn.size());
    for (size_t i = 0; i < tn.size(); ++i) EXPECT_NEAR(fit.model.num[i], tn[i], 1e-6) << i;
    EXPECT_EQ(fit.reflected, 0);
    for (const measure::DecadeError& e : fit.decades) EXPECT_LT(e.max_rel, 1e-6);
}

TEST(TfFit, RecoversAContinuousResonance) {
    const double w = 2 * M_PI * 1500.0, z = 0.08;
    design::Tf truth{{w * w}, {1.0, 2 * z * w, w * w}, 0.0};
    const std::vector<double> f = lines(150, 20.0, 4000.0);
    std::vector<cplx> g;
    for (const double x : f) g.push_back(design::evaluate(truth, cplx(0, 2 * M_PI * x)) * std::polar(1.0, -2 * M_PI * x * kTs));
    measure::TfFitOptions o;
    o.poles = 2;
    o.zeros = 0;
    o.delay_samples = 1;
    o.continuous = true;
    o.ts = kTs;
    const measure::TfFit fit = measure::fit_tf(f, g, {}, o);
    EXPECT_NEAR(fit.model.den[1] / truth.den[1], 1.0, 1e-6);
    EXPECT_NEAR(fit.model.den[2] / truth.den[2], 1.0, 1e-6);
    EXPECT_NEAR(fit.model.num[0] / truth.num[0], 1.0, 1e-6);
    EXPECT_DOUBLE_EQ(fit.delay_s, kTs);
}

TEST(TfFit, ReflectsAnUnstablePole) {
    const std::vector<cplx> poles = {1.05, 0.5};
    const design::Tf truth = discrete_model(poles, {1.0, 0.2}, 1);
    const std::vector<double> f = lines(100, 10.0, 4500.0);
    measure::TfFitOptions o;
    o.poles = 2;
    o.zeros = 1;
    o.delay_samples = 1;
    o.ts = kTs;
    const measure::TfFit fit = measure::fit_tf(f, response(truth, f), {}, o);
    EXPECT_EQ(fit.reflected, 1);
    // The unstable pole at 1.05 comes back at 1 / 1.05; the other stays.
    std::vector<double> radii;
    for (const cplx p : fit.poles) radii.push_back(std::abs(p));
    std::sort(radii.begin(), radii.end());
    EXPECT_NEAR(radii[0], 0.5, 1e-6);
    EXPECT_NEAR(radii[1], 1.0 / 1.05, 1e-6);
}

TEST(TfFit, RefusesOrdersTheDataCannotSupport) {
    const std::vector<cplx> poles = {pole_of(800.0, 0.1), std::conj(pole_of(800.0, 0.1))};
    const design::Tf truth = discrete_model(poles, {0.1, 0.05}, 1);
    measure::TfFitOptions o;
    o.ts = kTs;
    o.delay_samples = 1;
    // More coefficients than lines.
    const std::vector<double> few = lines(5, 100.0, 3000.0);
    o.poles = 4;
    o.zeros = 3;
    try {
        (void)measure::fit_tf(few, response(truth, few), {}, o);
        FAIL() << "accepted 8 coefficients from 5 lines";
    } catch (const std::invalid_argument& e) {
        EXPECT_NE(std::string(e.what()).find("cannot support"), std::string::npos) << e.what();
    }
    // Exact second-order data and a fourth-order fit: a common factor of B
    // and A is free, the least-squares problem singular.
    const std::vector<double> f = lines(100, 10.0, 4000.0);
    try {
        (void)measure::fit_tf(f, response(truth, f), {}, o);
        FAIL() << "accepted a rank-deficient problem";
    } catch (const std::invalid_argument& e) {
        EXPECT_NE(std::string(e.what()).find("singular"), std::string::npos) << e.what();
    }
}
