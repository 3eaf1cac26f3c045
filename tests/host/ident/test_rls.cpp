// RLS and ARX / output-error identification (host/ident/rls.hpp).
// References: closed-form (weighted, regularised) least squares that the
// recursion must reproduce exactly; numpy's batch ARX estimate
// (tools/ref/ident_rls.py); recovery of known parameters from simulated
// data with seeded noise, judged against the estimate's standard errors.
#include <gtest/gtest.h>

#include <cmath>
#include <fstream>
#include <nlohmann/json.hpp>
#include <random>
#include <stdexcept>
#include <string>
#include <vector>

#include "ident/rls.hpp"
#include "test_support.hpp"

using namespace piezoloop::design;
using piezoloop::test::error_of;

namespace {

nlohmann::json golden() {
    std::ifstream f(std::string(PIEZOLOOP_GOLDEN_DIR) + "/ident_rls.json");
    return nlohmann::json::parse(f);
}

// y = B/F u filtered directly (independent of simulate_arx): F = 1 + f1 q^-1 + ...,
// B = b0 q^-d + b1 q^-(d+1) + ...
std::vector<double> filter(const std::vector<double>& f, const std::vector<double>& b, int d,
                           const std::vector<double>& u) {
    std::vector<double> y(u.size(), 0.0);
    for (std::size_t k = 0; k < u.size(); ++k) {
        double acc = 0.0;
        for (std::size_t j = 0; j < b.size(); ++j)
            if (k >= j + d) acc += b[j] * u[k - j - d];
        for (std::size_t i = 0; i < f.size(); ++i)
            if (k >= i + 1) acc -= f[i] * y[k - i - 1];
        y[k] = acc;
    }
    return y;
}

std::vector<double> random_binary(std::mt19937_64& rng, int n) {
    std::uniform_int_distribution<int> hold(1, 3), sign(0, 1);
    std::vector<double> u;
    while (static_cast<int>(u.size()) < n) {
        const double v = sign(rng) ? 1.0 : -1.0;
        for (int h = hold(rng); h > 0 && static_cast<int>(u.size()) < n; --h) u.push_back(v);
    }
    return u;
}

TEST(IdentRls, RecursionEqualsWeightedRegularisedLeastSquares) {
    // With W0 and forgetting lambda, after N samples RLS minimises
    //   sum_k lambda^(N-1-k) (y_k - phi_k' psi)^2 + lambda^N psi' W0^-1 psi,
    // whose normal equations are solved here directly.
    std::mt19937_64 rng(7);
    std::normal_distribution<double> g(0.0, 1.0);
    const int n = 4, samples = 300;
    Eigen::VectorXd truth(n);
    truth << 0.5, -1.0, 2.0, 0.25;
    Eigen::VectorXd w0(n);
    w0 << 10.0, 100.0, 1.0, 1000.0;
    for (double lambda : {1.0, 0.98}) {
        Rls rls(w0, lambda);
        Eigen::MatrixXd normal = w0.cwiseInverse().asDiagonal();
        normal *= std::pow(lambda, samples);
        Eigen::VectorXd rhs = Eigen::VectorXd::Zero(n);
        std::vector<Eigen::VectorXd> phis;
        std::vector<double> ys;
        for (int k = 0; k < samples; ++k) {
            Eigen::VectorXd phi(n);
            for (int i = 0; i < n; ++i) phi(i) = g(rng);
            const double y = phi.dot(truth) + 0.1 * g(rng);
            rls.update(phi, y);
            phis.push_back(phi);
            ys.push_back(y);
        }
        for (int k = 0; k < samples; ++k) {
            const double w = std::pow(lambda, samples - 1 - k);
            normal += w * phis[k] * phis[k].transpose();
            rhs += w * phis[k] * ys[k];
        }
        const Eigen::VectorXd want = normal.ldlt().solve(rhs);
        // Both in double on a well-conditioned problem (cond < 1e3): the
        // recursion's rounding stays near 1e-13; 1e-10 leaves margin.
        for (int i = 0; i < n; ++i) EXPECT_NEAR(rls.parameters()(i), want(i), 1e-10) << lambda << " " << i;
        // The covariance is the inverse of the normal matrix (times lambda^0).
        const Eigen::MatrixXd cov = normal.inverse();
        EXPECT_LT((rls.covariance() - cov).norm(), 1e-10 * cov.norm()) << lambda;
    }
}

TEST(IdentRls, ForgettingTracksAParameterChange) {
    // ARX parameters switch halfway; with lambda = 0.95 (memory ~20 samples)
    // the final estimate is the second system's, without forgetting it is a
    // blend. Noise-free, so the tracked estimate is exact up to the decayed
    // influence of the first half (0.95^500 ~ 7e-12).
    std::mt19937_64 rng(3);
    const std::vector<double> u = random_binary(rng, 1000);
    const std::vector<double> y1 = filter({-1.5, 0.7}, {1.0, 0.5}, 1, u);
    std::vector<double> y(y1.begin(), y1.begin() + 500);
    // Continue the second system from the first one's state at the switch.
    for (int k = 500; k < 1000; ++k)
        y.push_back(1.2 * y[k - 1] - 0.5 * y[k - 2] + 0.5 * u[k - 1] + 0.25 * u[k - 2]);
    LinearIdentSpec spec;
    spec.forgetting = 0.95;
    const LinearIdentResult tracked = identify_linear(u, y, 1e-3, spec);
    EXPECT_NEAR(tracked.a[0], -1.2, 1e-8);
    EXPECT_NEAR(tracked.a[1], 0.5, 1e-8);
    EXPECT_NEAR(tracked.b[0], 0.5, 1e-8);
    EXPECT_NEAR(tracked.b[1], 0.25, 1e-8);
    spec.forgetting = 1.0;
    const LinearIdentResult blended = identify_linear(u, y, 1e-3, spec);
    EXPECT_GT(std::fabs(blended.a[0] + 1.2), 0.01);
}

TEST(IdentRls, ArxMatchesNumpyBatchEstimateAndRecoversTheSystem) {
    const auto g = golden();
    const std::vector<double> u = g["u"], y = g["y"];
    LinearIdentSpec spec;  // ARX na = 2, nb = 2, delay 1
    const LinearIdentResult r = identify_linear(u, y, g["ts"].get<double>(), spec);
    ASSERT_EQ(r.a.size(), 2u);
    ASSERT_EQ(r.b.size(), 2u);
    // RLS from W0 = 1e6/mean(phi_i^2) is the LS estimate with a ridge of
    // 1e-6 of one sample per regressor: over ~1000 rows a relative pull of
    // ~1e-9 times the conditioning (< 100). 1e-6 covers it.
    for (int i = 0; i < 2; ++i) {
        EXPECT_NEAR(r.a[i], g["lstsq"]["a"][i].get<double>(), 1e-6);
        EXPECT_NEAR(r.b[i], g["lstsq"]["b"][i].get<double>(), 1e-6);
    }
    // Recovery: the true parameters lie within 4 standard errors
    // sigma * sqrt(diag((Phi' Phi)^-1)) of the estimate (ARX with white
    // equation noise is unbiased; 4 sigma fails by chance with p < 1e-4).
    const double sigma = g["true"]["noise_sigma"];
    Eigen::MatrixXd phi(u.size() - 2, 4);
    for (std::size_t k = 2; k < u.size(); ++k)
        phi.row(k - 2) << -y[k - 1], -y[k - 2], u[k - 1], u[k - 2];
    const Eigen::VectorXd se = sigma * (phi.transpose() * phi).inverse().diagonal().cwiseSqrt();
    const double truth[4] = {-1.5, 0.7, 1.0, 0.5};
    const double est[4] = {r.a[0], r.a[1], r.b[0], r.b[1]};
    for (int i = 0; i < 4; ++i) EXPECT_LE(std::fabs(est[i] - truth[i]), 4 * se(i)) << i;

    // The model: z^-1 (b0 + b1 z^-1) / (1 + a1 z^-1 + a2 z^-2) = (b0 z + b1) / (z^2 + a1 z + a2).
    EXPECT_EQ(r.model.ts, 1e-4);
    ASSERT_EQ(r.model.den.size(), 3u);
    ASSERT_EQ(r.model.num.size(), 2u);
    EXPECT_EQ(r.model.den[0], 1.0);
    EXPECT_EQ(r.model.den[1], r.a[0]);
    EXPECT_EQ(r.model.num[0], r.b[0]);
    EXPECT_EQ(r.model.num[1], r.b[1]);
    EXPECT_TRUE(r.stable);
    EXPECT_EQ(r.method, "rls-arx");
    EXPECT_EQ(r.samples_used, 998);
    // Fit errors recomputed here: one-step residual ~ sigma (within 10 %:
    // 998 samples give a relative standard deviation of ~2 %), and the
    // simulation NRMSE from an independent simulation.
    EXPECT_NEAR(r.prediction_rms, sigma, 0.1 * sigma);
    std::vector<double> ys(y.begin(), y.begin() + 2);
    for (std::size_t k = 2; k < u.size(); ++k)
        ys.push_back(-r.a[0] * ys[k - 1] - r.a[1] * ys[k - 2] + r.b[0] * u[k - 1] + r.b[1] * u[k - 2]);
    double e2 = 0, d2 = 0, mean = 0;
    for (std::size_t k = 2; k < u.size(); ++k) mean += y[k] / 998.0;
    for (std::size_t k = 2; k < u.size(); ++k) {
        e2 += (y[k] - ys[k]) * (y[k] - ys[k]);
        d2 += (y[k] - mean) * (y[k] - mean);
    }
    EXPECT_NEAR(r.fit_percent, 100 * (1 - std::sqrt(e2 / d2)), 1e-9);
    EXPECT_NEAR(r.simulation_rms, std::sqrt(e2 / 998), 1e-12);
    EXPECT_GT(r.fit_percent, 80.0);
}

TEST(IdentRls, OutputErrorBySteiglitzMcBrideRecoversWhereArxIsBiased) {
    // y = B/F u + white noise: the ARX estimate is biased (the noise enters
    // its regressors through y), the OE estimate is not.
    std::mt19937_64 rng(11);
    std::normal_distribution<double> g(0.0, 1.0);
    const int n = 3000;
    const double sigma = 0.5;
    const std::vector<double> u = random_binary(rng, n);
    const std::vector<double> f{-1.5, 0.7}, b{1.0, 0.5};
    std::vector<double> y = filter(f, b, 1, u);
    for (double& v : y) v += sigma * g(rng);

    LinearIdentSpec spec;
    spec.structure = LinearStructure::kOutputError;
    const LinearIdentResult oe = identify_linear(u, y, 1e-4, spec);
    EXPECT_TRUE(oe.converged);
    EXPECT_EQ(oe.method, "steiglitz-mcbride-oe");
    // Standard errors of the OE estimate: sigma^2 (Psi' Psi)^-1 with Psi
    // the gradient regressors [-x_f[k-1], -x_f[k-2], u_f[k-1], u_f[k-2]],
    // x = B/F u the noise-free output, _f = filtered by 1/F (first-order
    // asymptotics of the prediction-error estimate). 4 standard errors.
    const std::vector<double> one{1.0};
    const std::vector<double> x = filter(oe.a, oe.b, 1, u);
    const std::vector<double> xf = filter(oe.a, one, 0, x), uf = filter(oe.a, one, 0, u);
    Eigen::MatrixXd psi(n - 2, 4);
    for (int k = 2; k < n; ++k) psi.row(k - 2) << -xf[k - 1], -xf[k - 2], uf[k - 1], uf[k - 2];
    const Eigen::VectorXd se = sigma * (psi.transpose() * psi).inverse().diagonal().cwiseSqrt();
    const double truth[4] = {-1.5, 0.7, 1.0, 0.5};
    const double est[4] = {oe.a[0], oe.a[1], oe.b[0], oe.b[1]};
    for (int i = 0; i < 4; ++i) EXPECT_LE(std::fabs(est[i] - truth[i]), 4 * se(i)) << i << " se " << se(i);
    // The simulation error of the OE model is the output noise itself.
    EXPECT_NEAR(oe.simulation_rms, sigma, 0.05 * sigma);

    spec.structure = LinearStructure::kArx;
    const LinearIdentResult arx = identify_linear(u, y, 1e-4, spec);
    EXPECT_GT(std::fabs(arx.a[1] - 0.7), 10 * se(1)) << "ARX should be visibly biased here";
    EXPECT_GT(oe.fit_percent, arx.fit_percent);
}

TEST(IdentRls, DelayAndOrdersShapeTheTransferFunction) {
    // delay 3, nb 1, na 1: b0 z^-3 / (1 + a1 z^-1) = b0 / (z^3 + a1 z^2).
    std::mt19937_64 rng(5);
    const std::vector<double> u = random_binary(rng, 400);
    const std::vector<double> y = filter({-0.9}, {0.2}, 3, u);
    LinearIdentSpec spec;
    spec.na = 1;
    spec.nb = 1;
    spec.delay = 3;
    const LinearIdentResult r = identify_linear(u, y, 0.5, spec);
    // Noise-free: exact up to the RLS prior (1e-6 of a sample, ~1e-9 here).
    EXPECT_NEAR(r.a[0], -0.9, 1e-7);
    EXPECT_NEAR(r.b[0], 0.2, 1e-7);
    ASSERT_EQ(r.model.den.size(), 4u);
    EXPECT_EQ(r.model.den[2], 0.0);
    EXPECT_EQ(r.model.den[3], 0.0);
    ASSERT_EQ(r.model.num.size(), 1u);
    EXPECT_NEAR(r.fit_percent, 100.0, 1e-4);
}

TEST(IdentRls, RefusesDataThatCannotIdentifyTheModel) {
    std::mt19937_64 rng(1);
    const std::vector<double> u = random_binary(rng, 200);
    const std::vector<double> y = filter({-0.5}, {1.0}, 1, u);
    LinearIdentSpec spec;

    const std::vector<double> flat(200, 1.0);
    EXPECT_EQ(error_of([&] { identify_linear(flat, y, 1.0, spec); }), "u: no excitation: the input is constant");

    // A single sinusoid is persistently exciting of order 2 only: three
    // consecutive input regressors are linearly dependent.
    std::vector<double> sine(200);
    for (int k = 0; k < 200; ++k) sine[k] = std::sin(0.3 * k);
    spec.nb = 3;
    const std::vector<double> ys = filter({-0.5}, {1.0, 0.2, 0.1}, 1, sine);
    const std::string dep = error_of([&] { identify_linear(sine, ys, 1.0, spec); });
    EXPECT_EQ(dep.rfind("u: regressors are linearly dependent", 0), 0u) << dep;
    EXPECT_NE(dep.find("u[k-1], u[k-2], u[k-3]"), std::string::npos) << dep;
    spec.nb = 2;

    const std::string shrt = error_of([&] {
        identify_linear(std::span<const double>(u.data(), 15), std::span<const double>(y.data(), 15), 1.0, spec);
    });
    EXPECT_EQ(shrt.rfind("u: too short", 0), 0u) << shrt;

    std::vector<double> ynan = y;
    ynan[17] = std::nan("");
    EXPECT_EQ(error_of([&] { identify_linear(u, ynan, 1.0, spec); }), "y: sample 17 is not finite (NaN/Inf)");

    spec.input_name = "v_V";
    spec.output_name = "x_um";
    EXPECT_EQ(error_of([&] { identify_linear(u, std::span<const double>(y.data(), 100), 1.0, spec); })
                  .rfind("x_um: has 100 samples but v_V has 200", 0),
              0u);
    EXPECT_EQ(error_of([&] { identify_linear(flat, y, 1.0, spec); }), "v_V: no excitation: the input is constant");
    spec = LinearIdentSpec{};
    spec.na = 21;
    EXPECT_EQ(error_of([&] { identify_linear(u, y, 1.0, spec); }), "na: must be in [0, 20]");
    spec = LinearIdentSpec{};
    spec.forgetting = 0.0;
    EXPECT_EQ(error_of([&] { identify_linear(u, y, 1.0, spec); }), "forgetting: must be in (0, 1]");
    spec = LinearIdentSpec{};
    EXPECT_EQ(error_of([&] { identify_linear(u, y, 0.0, spec); }), "ts: sample period must be finite and > 0");
    spec.structure = LinearStructure::kOutputError;
    spec.na = 0;
    EXPECT_NE(error_of([&] { identify_linear(u, y, 1.0, spec); }).find("na:"), std::string::npos);
}

}  // namespace
