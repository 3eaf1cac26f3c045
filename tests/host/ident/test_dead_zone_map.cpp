// Superposition of dead zones (host/ident/dead_zone_map.hpp): values and
// slopes against hand-computed ones, the inverse against the definition.
#include <gtest/gtest.h>

#include <stdexcept>
#include <string>

#include "ident/dead_zone_map.hpp"
#include "test_support.hpp"

using namespace piezoloop::design;
using piezoloop::test::error_of;

namespace {

TEST(DeadZoneMap, ValuesSlopesAndInverse) {
    // f(x) = x + 0.5 max(x - 1, 0) - 1 max(x - 3, 0): slopes 1, 1.5, 0.5.
    const DeadZoneMap f{{1.0, 3.0}, {0.5, -1.0}};
    EXPECT_EQ(f.apply(0.0), 0.0);
    EXPECT_EQ(f.apply(2.0), 2.5);
    EXPECT_EQ(f.apply(5.0), 5.0 + 2.0 - 2.0);
    EXPECT_EQ(f.slopes(), (std::vector<double>{1.0, 1.5, 0.5}));
    EXPECT_EQ(f.monotonicity(), "ok");
    // Inverse by hand: identity up to f(1) = 1, slope 1/1.5 up to f(3) = 4,
    // then 1/0.5 = 2.
    const DeadZoneMap g = inverse(f);
    ASSERT_EQ(g.thresholds.size(), 2u);
    EXPECT_DOUBLE_EQ(g.thresholds[0], 1.0);
    EXPECT_DOUBLE_EQ(g.thresholds[1], 4.0);
    EXPECT_DOUBLE_EQ(g.weights[0], 1.0 / 1.5 - 1.0);
    EXPECT_DOUBLE_EQ(g.weights[1], 2.0 - 1.0 / 1.5);
    for (double x = -2.0; x <= 8.0; x += 0.25) EXPECT_NEAR(g.apply(f.apply(x)), x, 1e-14) << x;
}

TEST(DeadZoneMap, RefusesAMapThatIsNotIncreasing) {
    const DeadZoneMap f{{1.0, 2.0}, {-0.5, -0.6}};  // slopes 1, 0.5, -0.1
    EXPECT_NE(f.monotonicity().find("slope -0.1 above 2 is not > 0"), std::string::npos) << f.monotonicity();
    EXPECT_EQ(error_of([&] { inverse(f); }).rfind("output nonlinearity: slope -0.1", 0), 0u);
}

}  // namespace
