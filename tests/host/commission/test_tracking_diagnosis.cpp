// Diagnosis of a tracking record against records whose causes are known by
// construction: the fractions are counted exactly over the last period, the
// oscillation's frequency is a sinusoid's on an FFT bin.
#include "commission/tracking_diagnosis.hpp"

#include <cmath>
#include <numbers>
#include <stdexcept>

#include <gtest/gtest.h>

namespace piezoloop::commission {
namespace {

constexpr double kRate = 10000.0;

TrackingDiagnosisInputs inputs() {
    TrackingDiagnosisInputs in;
    in.rate_Hz = kRate;
    in.triangle_Hz = 10.0;
    in.range_um = 10.0;
    in.u_min_V = 0.0;
    in.u_max_V = 10.0;
    in.sensor_min_um = -2.0;
    in.sensor_max_um = 18.0;
    return in;
}

// Two periods of a 10 Hz triangle from 0 to 10 µm, tracked exactly, u = r.
struct Record {
    std::vector<double> r, y, u;
    Record() {
        for (int k = 0; k < 2000; ++k) {
            const double phase = std::fmod(k / 1000.0, 1.0);
            const double v = 10.0 * (phase < 0.5 ? 2.0 * phase : 2.0 - 2.0 * phase);
            r.push_back(v);
            y.push_back(v);
            u.push_back(0.5 + 0.9 * v);
        }
    }
};

TEST(TrackingDiagnosis, ExactTrackingShowsNothing) {
    const Record rec;
    const TrackingDiagnosis d = diagnose_tracking(rec.r, rec.y, rec.u, inputs());
    EXPECT_EQ(d.limited_fraction, 0.0);
    EXPECT_EQ(d.rail_fraction, 0.0);
    EXPECT_EQ(d.oscillation_Hz, 0.0);
    EXPECT_EQ(describe(d, inputs()), "");
}

TEST(TrackingDiagnosis, CountsTicksAtACommandLimitInTheLastPeriod) {
    Record rec;
    for (int k = 0; k < 1000; ++k) rec.u[static_cast<std::size_t>(k)] = 10.0;  // the first period: not counted
    EXPECT_EQ(diagnose_tracking(rec.r, rec.y, rec.u, inputs()).limited_fraction, 0.0);
    for (int k = 1000; k < 1300; ++k) rec.u[static_cast<std::size_t>(k)] = 10.0;  // at u_max
    for (int k = 1300; k < 1400; ++k) rec.u[static_cast<std::size_t>(k)] = 0.0;   // at u_min
    const TrackingDiagnosis d = diagnose_tracking(rec.r, rec.y, rec.u, inputs());
    EXPECT_DOUBLE_EQ(d.limited_fraction, 400.0 / 1000.0);
    EXPECT_NE(describe(d, inputs()).find("saturation"), std::string::npos);
}

TEST(TrackingDiagnosis, ARailNeedsTenReadingsAtAnEnd) {
    Record rec;
    for (int k = 1000; k < 1009; ++k) rec.y[static_cast<std::size_t>(k)] = 18.0;
    EXPECT_EQ(diagnose_tracking(rec.r, rec.y, rec.u, inputs()).rail_fraction, 0.0);
    rec.y[1009] = -2.0;
    const TrackingDiagnosis d = diagnose_tracking(rec.r, rec.y, rec.u, inputs());
    EXPECT_DOUBLE_EQ(d.rail_fraction, 10.0 / 1000.0);
    EXPECT_NE(describe(d, inputs()).find("sensor rail"), std::string::npos);
}

// A sinusoid at 1.5 kHz (bin 150 of the last period's 1000 samples at
// 10 kHz) added to y: found at its frequency; growing when its amplitude
// doubles every half period.
TEST(TrackingDiagnosis, FindsTheOscillationAndWhetherItGrows) {
    for (const bool grow : {false, true}) {
        Record rec;
        for (std::size_t k = 0; k < rec.y.size(); ++k) {
            const double a = 0.2 * (grow ? std::exp2(static_cast<double>(k) / 500.0) : 1.0);
            rec.y[k] += a * std::sin(2.0 * std::numbers::pi * 1500.0 * static_cast<double>(k) / kRate);
        }
        const TrackingDiagnosis d = diagnose_tracking(rec.r, rec.y, rec.u, inputs());
        EXPECT_DOUBLE_EQ(d.oscillation_Hz, 1500.0) << grow;
        EXPECT_EQ(d.growing, grow);
        EXPECT_NE(describe(d, inputs()).find(grow ? "instability" : "rings"), std::string::npos);
    }
}

// Below 0.5 % of the range (0.05 µm RMS here) the fast part is noise, not
// an oscillation.
TEST(TrackingDiagnosis, SmallRippleIsNotAnOscillation) {
    Record rec;
    for (std::size_t k = 0; k < rec.y.size(); ++k)
        rec.y[k] += 0.06 * std::sin(2.0 * std::numbers::pi * 1500.0 * static_cast<double>(k) / kRate);  // 0.042 RMS
    EXPECT_EQ(diagnose_tracking(rec.r, rec.y, rec.u, inputs()).oscillation_Hz, 0.0);
}

TEST(TrackingDiagnosis, RefusesMismatchedRecords) {
    Record rec;
    rec.u.pop_back();
    EXPECT_THROW(diagnose_tracking(rec.r, rec.y, rec.u, inputs()), std::invalid_argument);
}

}  // namespace
}  // namespace piezoloop::commission
