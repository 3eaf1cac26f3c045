// Tustin transform of one section against scipy.signal.bilinear
// (tools/ref/tustin_ref.py).
#include <gtest/gtest.h>

#include <fstream>
#include <nlohmann/json.hpp>

#include "piezoloop/tustin.hpp"

using namespace piezoloop;

TEST(Tustin, MatchesScipyBilinear) {
    std::ifstream f(std::string(PIEZOLOOP_GOLDEN_DIR) + "/tustin_ref.json");
    const auto cases = nlohmann::json::parse(f);
    ASSERT_GE(cases.size(), 4u);
    for (const auto& c : cases) {
        const auto n = c["num"].get<std::vector<double>>();
        const auto d = c["den"].get<std::vector<double>>();
        SosSection s;
        ASSERT_TRUE(tustin({n[0], n[1], n[2], d[0], d[1], d[2]}, c["rate"].get<double>(), s).ok());
        const auto b = c["b"].get<std::vector<double>>();
        const auto a = c["a"].get<std::vector<double>>();
        // Same algebra in double on both sides, different operation order:
        // a few ulp of the largest term, relative 1e-12.
        const double got[] = {s.b0, s.b1, s.b2, s.a1, s.a2};
        const double want[] = {b[0], b[1], b[2], a[1], a[2]};
        for (int i = 0; i < 5; ++i)
            EXPECT_NEAR(got[i], want[i], 1e-12 * (1.0 + std::fabs(want[i]))) << c["name"] << " coef " << i;
    }
}

TEST(Tustin, PresetsHaveUnitDcGain) {
    // Tustin maps s = 0 to z = 1, so H(z=1) = sum b / (1 + a1 + a2) = H(0) = 1.
    SosSection s;
    ASSERT_TRUE(tustin(resonance(1e3, 0.02), 1e5, s).ok());
    EXPECT_NEAR((s.b0 + s.b1 + s.b2) / (1.0 + s.a1 + s.a2), 1.0, 1e-9);
    ASSERT_TRUE(tustin(first_order_lag(3e3), 1e5, s).ok());
    EXPECT_NEAR((s.b0 + s.b1 + s.b2) / (1.0 + s.a1 + s.a2), 1.0, 1e-12);
    EXPECT_FALSE(tustin(resonance(1e3, 0.02), -1.0, s).ok());
}
