// Metrics (docs/models.md, 'Metrics') against analytic values.
#include <gtest/gtest.h>

#include <cmath>
#include <vector>

#include "sim/metrics.hpp"

using namespace piezoloop::sim;

TEST(Metrics, HysteresisOfPhaseShiftedSineIsSinPhi) {
    // v = sin t, x = sin(t - phi): at v = 0 the branches give -sin phi and
    // +sin phi, the output range is 2, so hyst% = 100 sin phi. 4000 samples a
    // period: linear interpolation error (dt^2/8 ~ 3e-7) is far below 1e-4 %.
    for (double phi : {0.0, 0.1, 0.3, 1.0}) {
        std::vector<double> v, x;
        for (int k = 0; k < 4000; ++k) {
            const double t = 2.0 * M_PI * (k + 0.37) / 4000.0;
            v.push_back(std::sin(t));
            x.push_back(std::sin(t - phi));
        }
        EXPECT_NEAR(hysteresis_pct(v, x), 100.0 * std::sin(phi), 1e-4) << phi;
    }
}

TEST(Metrics, HysteresisNeedsBothCrossings) {
    const std::vector<double> v = {0.0, 1.0, 2.0, 3.0}, x = {0.0, 1.0, 2.0, 3.0};
    // Cyclic: 3 -> 0 is a falling crossing, 0 -> 1 -> 2 rising: a line, 0 %.
    EXPECT_NEAR(hysteresis_pct(v, x), 0.0, 1e-12);
    const std::vector<double> flat = {1.0, 1.0, 1.0};
    EXPECT_LT(hysteresis_pct(flat, flat), 0.0);
}

TEST(Metrics, TrackingOfKnownError) {
    // r = triangle 0..10, y = r - 0.1 sin: e = 0.1 sin, max 0.1, RMS 0.1/sqrt 2.
    std::vector<double> r, y;
    const int n = 1000;
    for (int k = 0; k < n; ++k) {
        const double ph = static_cast<double>(k) / n;
        const double tri = ph < 0.5 ? 20.0 * ph : 20.0 * (1.0 - ph);
        r.push_back(tri);
        y.push_back(tri - 0.1 * std::sin(2.0 * M_PI * ph));
    }
    const TrackingMetrics m = tracking_metrics(r, y);
    EXPECT_NEAR(m.range_um, 10.0, 1e-12);  // k = 500 samples the peak exactly
    EXPECT_NEAR(m.e_max_um, 0.1, 1e-6);
    EXPECT_NEAR(m.e_pp_um, 0.2, 1e-6);
    EXPECT_NEAR(m.e_rms_um, 0.1 / std::sqrt(2.0), 1e-9);  // exact for full periods
    EXPECT_NEAR(m.e_max_pct, 1.0, 1e-5);
}
