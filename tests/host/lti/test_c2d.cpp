// host/lti/c2d against tests/golden/design_c2d.json
// (tools/ref/design_c2d.py: the exact responses of the Tustin, ZOH and
// matched discretisations from mpmath at 60 digits; scipy's bilinear_zpk
// and cont2discrete for comparison), plus analytic cases.
#include <gtest/gtest.h>

#include <cmath>
#include <fstream>
#include <numbers>
#include <stdexcept>
#include <string>
#include <vector>

#include <nlohmann/json.hpp>

#include "lti/c2d.hpp"
#include "lti/freqresp.hpp"
#include "lti/lti_convert.hpp"

using namespace piezoloop::design;
using nlohmann::json;

namespace {

const json& golden() {
    static const json j = [] {
        std::ifstream f(std::string(PIEZOLOOP_GOLDEN_DIR) + "/design_c2d.json");
        return json::parse(f);
    }();
    return j;
}

std::vector<cplx> cplx_vec(const json& a) {
    std::vector<cplx> out;
    for (const auto& v : a) out.emplace_back(v[0].get<double>(), v[1].get<double>());
    return out;
}

Zpk factored(const json& c) {
    std::vector<Zpk> parts;
    for (const auto& f : c["factors"]) {
        Zpk z = tf2zpk(Tf{f["num"].get<std::vector<double>>(), f["den"].get<std::vector<double>>()});
        z.gain *= f["gain"].get<double>();
        parts.push_back(z);
    }
    return series(parts);
}

double root_error(std::vector<cplx> got, const std::vector<cplx>& want) {
    if (got.size() != want.size()) return INFINITY;
    double worst = 0.0;
    for (const cplx& w : want) {
        size_t best = 0;
        for (size_t i = 1; i < got.size(); ++i)
            if (std::abs(got[i] - w) < std::abs(got[best] - w)) best = i;
        // Relative to the distance from z = 1 (what sets the response near
        // DC) or to |w| when that is larger.
        worst = std::max(worst, std::abs(got[best] - w) / std::max(std::abs(1.0 - w), 1e-300));
        got.erase(got.begin() + static_cast<std::ptrdiff_t>(best));
    }
    return worst;
}

}  // namespace

TEST(DesignC2d, ResponsesMatchExactDiscretisations) {
    for (const auto& c : golden()) {
        const std::string name = c["name"];
        const double rate = c["rate_hz"], prewarp = c["prewarp_hz"];
        const Zpk d = c2d(factored(c), 1.0 / rate, parse_c2d_method(c["method"]),
                          2.0 * std::numbers::pi * prewarp);
        EXPECT_EQ(d.ts, 1.0 / rate);
        const std::vector<cplx> want = cplx_vec(c["h"]);
        const std::vector<cplx> got = freqresp(d, hz_to_rad_s(c["freqs_hz"].get<std::vector<double>>()));
        double worst = 0.0;
        for (size_t i = 0; i < want.size(); ++i) worst = std::max(worst, std::abs(got[i] - want[i]) / std::abs(want[i]));
        // Tustin / matched: each root maps with a few roundings; near z = 1
        // (K's slow pair, |1 - z| ~ 3e-5) that is ~eps / 3e-5 ~ 1e-11
        // relative in |z - 1|, and the factored evaluation adds ~1e-15 per
        // factor: 1e-9 leaves two orders of margin.
        // ZOH: expm of the balanced cascade (Padé, backward error ~eps |A
        // Ts|), zeros from ss2zpk (absolute error ~eps |Phi| ~ 2e-16 on
        // zeros within 3e-5 of z = 1) and the gain along the deflation:
        // 1e-7, observed ~1e-9 and below.
        const double tol = c["method"] == "zoh" ? 1e-7 : 1e-9;
        EXPECT_LE(worst, tol) << name;
        std::printf("%-32s worst relative response error %.2e (tol %.0e)\n", name.c_str(), worst, tol);
    }
}

TEST(DesignC2d, TustinRootsMatchScipyBilinearZpk) {
    for (const auto& c : golden()) {
        if (!c.contains("scipy_poles")) continue;
        const std::string name = c["name"];
        const double rate = c["rate_hz"], prewarp = c["prewarp_hz"];
        const Zpk d = tustin(factored(c), 1.0 / rate, 2.0 * std::numbers::pi * prewarp);
        // Same map on the same (rounded) roots; the continuous roots here
        // come from our own tf2zpk of each factor and scipy's from mpmath,
        // both within an ulp or two: relative to |1 - z|, 1e-10.
        EXPECT_LE(root_error(d.poles, cplx_vec(c["scipy_poles"])), 1e-10) << name;
        EXPECT_LE(root_error(d.zeros, cplx_vec(c["scipy_zeros"])), 1e-10) << name;
        const double kg = c["scipy_gain"];
        EXPECT_NEAR(d.gain, kg, 1e-12 * std::fabs(kg)) << name;
    }
}

TEST(DesignC2d, ZohMatchesScipyCont2Discrete) {
    int checked = 0;
    for (const auto& c : golden()) {
        if (!c.contains("scipy_num")) continue;
        const std::string name = c["name"];
        const double rate = c["rate_hz"];
        const Tf t = zpk2tf(zoh(factored(c), 1.0 / rate));
        std::vector<double> num = c["scipy_num"], den = c["scipy_den"];
        while (!num.empty() && num[0] == 0.0) num.erase(num.begin());
        ASSERT_EQ(t.den.size(), den.size()) << name;
        ASSERT_EQ(t.num.size(), num.size()) << name;
        // Low order, well conditioned: coefficients to 1e-12 of the largest.
        for (size_t i = 0; i < den.size(); ++i) EXPECT_NEAR(t.den[i], den[i] / den[0], 1e-12 * 2.0) << name;
        for (size_t i = 0; i < num.size(); ++i) EXPECT_NEAR(t.num[i], num[i] / den[0], 1e-12) << name;
        ++checked;
    }
    EXPECT_GE(checked, 2);
}

TEST(DesignC2d, AnalyticFirstOrderLag) {
    // a / (s + a) at Ts: ZOH gives (1 - e^{-aT}) / (z - e^{-aT}) exactly;
    // Tustin maps the pole to (K - a)/(K + a) with a zero at -1; matched
    // gives k (z + 1)/(z - e^{-aT}) with k = (1 - e^{-aT}) / 2.
    const double a = 2.0 * std::numbers::pi * 1e3, ts = 1e-5, e = std::exp(-a * ts);
    const Zpk lag{{}, {cplx(-a)}, a};
    const Zpk zd = zoh(lag, ts);
    ASSERT_EQ(zd.poles.size(), 1u);
    EXPECT_TRUE(zd.zeros.empty());
    EXPECT_NEAR(zd.poles[0].real(), e, 1e-15);
    EXPECT_NEAR(zd.gain, 1.0 - e, 1e-14);  // expm of a 2x2: ~eps relative
    const Zpk td = tustin(lag, ts);
    const double k2 = 2.0 / ts;
    EXPECT_NEAR(td.poles[0].real(), (k2 - a) / (k2 + a), 1e-15);
    ASSERT_EQ(td.zeros.size(), 1u);
    EXPECT_EQ(td.zeros[0], cplx(-1.0));
    EXPECT_NEAR(dc_gain(td), 1.0, 1e-14);
    const Zpk md = matched(lag, ts);
    EXPECT_NEAR(md.gain, 0.5 * (1.0 - e), 1e-15);
    EXPECT_EQ(md.zeros[0], cplx(-1.0));
    // Pre-warped Tustin reproduces the continuous response at the warp
    // frequency exactly (to rounding).
    const double wp = 2.0 * std::numbers::pi * 20e3;
    const cplx hc = evaluate(lag, cplx(0.0, wp));
    const cplx hd = freqresp(tustin(lag, ts, wp), {wp})[0];
    EXPECT_NEAR(std::abs(hd - hc), 0.0, 1e-13);
    // Without pre-warp it does not (20 kHz at 100 kHz is warped by ~14 %).
    EXPECT_GT(std::abs(freqresp(tustin(lag, ts), {wp})[0] - hc), 1e-3);
}

TEST(DesignC2d, IntegratorMapsToZEqualsOne) {
    // 1/s: ZOH gives Ts / (z - 1); matched matches the magnitude at 1e-3
    // Nyquist instead of DC.
    const double ts = 1e-4;
    const Zpk integ{{}, {cplx(0.0)}, 1.0};
    const Zpk zd = zoh(integ, ts);
    EXPECT_EQ(zd.poles[0], cplx(1.0));
    EXPECT_NEAR(zd.gain, ts, 1e-18);
    const Zpk md = matched(integ, ts);
    const double w = 1e-3 * std::numbers::pi / ts;
    EXPECT_NEAR(std::abs(freqresp(md, {w})[0]), 1.0 / w, 1e-12 / w);
}

TEST(DesignC2d, Errors) {
    const Zpk lag{{}, {cplx(-1.0)}, 1.0};
    EXPECT_THROW(c2d(lag, 0.0, C2dMethod::kTustin), std::invalid_argument);
    EXPECT_THROW(c2d(lag, -1e-3, C2dMethod::kZoh), std::invalid_argument);
    EXPECT_THROW(tustin(lag, 1e-3, 2.0 * std::numbers::pi * 600.0), std::invalid_argument);  // above Nyquist
    EXPECT_THROW(c2d(Zpk{{}, {cplx(-1.0)}, 1.0, 1e-3}, 1e-3, C2dMethod::kTustin), std::invalid_argument);
    EXPECT_THROW(c2d(Zpk{{cplx(-1.0), cplx(-2.0)}, {cplx(-1.0)}, 1.0}, 1e-3, C2dMethod::kMatched),
                 std::invalid_argument);
    EXPECT_THROW(parse_c2d_method("foh"), std::invalid_argument);
    EXPECT_THROW(tustin(Zpk{{}, {cplx(2000.0)}, 1.0}, 1e-3), std::invalid_argument);  // pole at s = 2/Ts
}
