// configs/models/*.json: the published models (docs/models.md) transcribed once.
// Each check recomputes a property from the published numbers directly
// (DC gains, pole locations, the closed loop K·G) and compares with the
// file as parsed; G and K are also compared with the exact responses of
// tests/golden/design_convert.json (generated from the published numbers).
#include <gtest/gtest.h>

#include <cmath>
#include <fstream>
#include <numbers>
#include <string>
#include <vector>

#include <Eigen/Eigenvalues>
#include <nlohmann/json.hpp>

#include "lti/freqresp.hpp"
#include "lti/lti_convert.hpp"
#include "lti/model_json.hpp"

using namespace piezoloop::design;
using nlohmann::json;

namespace {

std::string config(const char* name) { return std::string(PIEZOLOOP_GOLDEN_DIR) + "/../../configs/models/" + name; }

Zpk load(const char* name) { return load_model_file(config(name)); }

const json& convert_golden() {
    static const json j = [] {
        std::ifstream f(std::string(PIEZOLOOP_GOLDEN_DIR) + "/design_convert.json");
        return json::parse(f);
    }();
    return j;
}

void expect_matches_golden(const Zpk& z, const char* golden_name) {
    for (const auto& m : convert_golden()["models"]) {
        if (m["name"] != golden_name) continue;
        const std::vector<double> w = convert_golden()["w_rad_s"].get<std::vector<double>>();
        const std::vector<cplx> h = freqresp(z, w);
        for (size_t i = 0; i < w.size(); ++i) {
            const cplx want(m["h"][i][0].get<double>(), m["h"][i][1].get<double>());
            // Same published numbers; our roots vs mpmath's: 1e-12.
            EXPECT_NEAR(std::abs(h[i] - want), 0.0, 1e-12 * std::abs(want)) << golden_name << " at " << w[i];
        }
        return;
    }
    ADD_FAILURE() << "no golden " << golden_name;
}

}  // namespace

TEST(DesignConfigs, EveryFileParsesAndIsDocumented) {
    for (const char* f : {"ahmad2020_G.json", "ahmad2020_K.json", "ahmad2020_Hm.json", "ahmad2020_He.json",
                          "ahmad2020_Hy.json", "janaideh2016_D.json", "janaideh2016_C.json", "shan2012_Q.json",
                          "shan2012_PI.json"}) {
        EXPECT_NO_THROW(load(f)) << f;
        std::ifstream in(config(f));
        const json j = json::parse(in);
        EXPECT_TRUE(j.contains("name") && j.contains("source")) << f;
    }
}

TEST(DesignConfigs, AhmadG) {
    const Zpk g = load("ahmad2020_G.json");
    EXPECT_EQ(g.poles.size(), 6u);
    EXPECT_EQ(g.zeros.size(), 3u);
    // DC gain = b0 / a0 from the published coefficients (roots: 1e-13).
    EXPECT_NEAR(dc_gain(g), 1.84e23 / 2.05e23, 1e-13);
    // Published coefficients back out of the roots: 1e-12 relative.
    const Tf t = zpk2tf(g);
    const std::vector<double> num{2.01e11, 4.74e15, 2.76e19, 1.84e23};
    const std::vector<double> den{1, 1.08e4, 2.95e8, 1.98e12, 1.65e16, 5.79e19, 2.05e23};
    for (size_t i = 0; i < num.size(); ++i) EXPECT_NEAR(t.num[i], num[i], 1e-12 * num[i]);
    for (size_t i = 0; i < den.size(); ++i) EXPECT_NEAR(t.den[i], den[i], 1e-12 * den[i]);
    expect_matches_golden(g, "ahmad2020_G");
}

TEST(DesignConfigs, AhmadKAndTheClosedLoop) {
    const Zpk k = load("ahmad2020_K.json");
    EXPECT_NEAR(dc_gain(k), 4.73e22 / 7.79e19, 1e-12 * 607.2);
    // docs/models.md, 'Published controllers': slowest pole pair near -3.2 +- 0.6j rad/s.
    EXPECT_NEAR(k.poles[0].real(), -3.2, 0.05);
    EXPECT_NEAR(std::fabs(k.poles[0].imag()), 0.6, 0.05);
    EXPECT_EQ(k.poles[1], std::conj(k.poles[0]));
    expect_matches_golden(k, "ahmad2020_K");
    // The d-order note: read as transcribed, the unity-feedback loop with
    // G(s) is stable. Closed loop of L = G K (D = 0): A - B C. Margin: the
    // slowest closed-loop pole must be clearly left of the axis (its
    // eigenvalue error is ~eps |A| ~ 1e-10).
    const Ss l = series(zpk2ss(k), zpk2ss(load("ahmad2020_G.json")));
    ASSERT_EQ(l.D, 0.0);
    const Eigen::MatrixXd acl = l.A - l.B * l.C;
    const Eigen::VectorXcd ev = acl.eigenvalues();
    double max_re = -INFINITY;
    for (Eigen::Index i = 0; i < ev.size(); ++i) max_re = std::max(max_re, ev(i).real());
    std::printf("Ahmad2020 K·G closed loop: largest real part of the poles %.4g rad/s\n", max_re);
    EXPECT_LT(max_re, -1e-3);
}

TEST(DesignConfigs, AhmadWeights) {
    // H_m: DC gain g M = 0.02, high-frequency gain g eps = 2e-10 (biproper).
    const Zpk hm = load("ahmad2020_Hm.json");
    EXPECT_NEAR(dc_gain(hm), 0.02, 1e-15);
    EXPECT_EQ(hm.zeros.size(), 5u);
    EXPECT_EQ(hm.poles.size(), 5u);
    EXPECT_NEAR(hm.gain, 0.02 * 1e-8, 1e-25);
    // Lightly damped resonance poles zeta 0.05 at 6.3e3 and 0.08 at 1.4e4.
    bool found1 = false, found2 = false;
    for (const cplx& p : hm.poles) {
        found1 = found1 || (std::fabs(std::abs(p) - 6.3e3) < 1e-6 && std::fabs(-p.real() / std::abs(p) - 0.05) < 1e-12);
        found2 = found2 || (std::fabs(std::abs(p) - 1.4e4) < 1e-6 && std::fabs(-p.real() / std::abs(p) - 0.08) < 1e-12);
    }
    EXPECT_TRUE(found1 && found2);
    expect_matches_golden(hm, "ahmad2020_Hm");
    // H_e: DC 1 / eps_e = 333.3, high frequency 1 / Me = 0.5.
    const Zpk he = load("ahmad2020_He.json");
    EXPECT_NEAR(dc_gain(he), 1.0 / 0.003, 1e-10);
    EXPECT_NEAR(he.gain, 0.5, 1e-15);
    // H_y: DC (1 / My)^2, high frequency (1 / eps_y)^2.
    const Zpk hy = load("ahmad2020_Hy.json");
    EXPECT_NEAR(dc_gain(hy), 1.0 / (1.5 * 1.5), 1e-14);
    EXPECT_NEAR(hy.gain, 1e8, 1e-6);
    expect_matches_golden(hy, "ahmad2020_Hy");
}

TEST(DesignConfigs, JanaidehD) {
    const Zpk d = load("janaideh2016_D.json");
    EXPECT_EQ(d.zeros.size(), 7u);
    EXPECT_EQ(d.poles.size(), 8u);
    // DC gain straight from the published factors, about 1.011.
    const double want = -20.7 * (-1.22e5) * 2.99e4 * (-2.776e4) * (-1.07e4) * 1430.0 * 3.2e9 /
                        (4.59e5 * 1.4e7 * 4e9 * 3.95e9);
    EXPECT_NEAR(dc_gain(d), want, 1e-12 * std::fabs(want));
    EXPECT_NEAR(dc_gain(d), 1.0, 0.02);  // "DC gain ~ 1" (Janaideh2016)
    // Non-minimum phase: three right-half-plane zeros.
    int rhp = 0;
    for (const cplx& z : d.zeros) rhp += z.real() > 0.0;
    EXPECT_EQ(rhp, 3);
    expect_matches_golden(d, "janaideh2016_D");
}

TEST(DesignConfigs, JanaidehC) {
    const Zpk c = load("janaideh2016_C.json");
    EXPECT_EQ(c.zeros.size(), 5u);
    EXPECT_EQ(c.poles.size(), 5u);
    const double want = 0.016 * 7.9e6 * 4.6e5 * 1.4e7 / (8.8e4 * 974.0 * 1.0 * 1.6e7);
    EXPECT_NEAR(dc_gain(c), want, 1e-12 * want);
    expect_matches_golden(c, "janaideh2016_C");
}

TEST(DesignConfigs, ShanQAndPI) {
    const Zpk q = load("shan2012_Q.json");
    EXPECT_EQ(q.ts, 1e-5);
    EXPECT_NEAR(dc_gain(q), 1.0, 1e-12);  // 0.3558 / (1 - 0.6442)
    // Cutoff ~ 7 kHz (docs/models.md, 'Repetitive control'): the -3 dB point of 0.3558 / (z - 0.6442).
    double f3 = 0.0;
    for (double f = 100.0; f < 50e3; f += 10.0)
        if (std::abs(freqresp(q, {2.0 * std::numbers::pi * f})[0]) < 1.0 / std::sqrt(2.0)) {
            f3 = f;
            break;
        }
    EXPECT_NEAR(f3, 7e3, 500.0);
    const Zpk pi = load("shan2012_PI.json");
    EXPECT_EQ(pi.ts, 1e-5);
    // Gc(z) = Kp + Ki Ts z / (z - 1), Kp 1.3, Ki 40000, at a few points.
    for (const cplx z : {cplx(0.5, 0.5), cplx(-0.3, 0.9), cplx(0.99, 0.01)}) {
        const cplx want = 1.3 + 40000.0 * 1e-5 * z / (z - 1.0);
        EXPECT_NEAR(std::abs(evaluate(pi, z) - want), 0.0, 1e-13 * std::abs(want));
    }
}
