// commission/commission: the safety step's checks on made-up records (each
// stop names the step and the reason), and the whole sequence on the
// shipped Ahmad2020 scenario: a controller is chosen that passes the checks
// on the measured response.
#include <gtest/gtest.h>

#include <cmath>
#include <numbers>
#include <utility>
#include <vector>
#include <stdexcept>
#include <string>

#include "commission/commission.hpp"
#include "commission/sim_stage.hpp"
#include "lti/freqresp.hpp"
#include "sim/scenario.hpp"

namespace piezoloop::commission {
namespace {

// A step record: 100 samples at y0 before t = 0, then 100 at y1, noise +-n alternating.
measure::StepRun record(double y0, double y1, double n) {
    measure::StepRun r;
    for (int i = -100; i < 100; ++i) {
        r.time_s.push_back(i * 1e-4);
        r.y_um.push_back((i < 0 ? y0 : y1) + (i % 2 == 0 ? n : -n));
    }
    r.figures.initial = y0;
    r.figures.final_value = y1;
    return r;
}

const measure::RangeUm kRails{0.0, 50.0};
const std::string kConfigs = std::string(PIEZOLOOP_GOLDEN_DIR) + "/../../configs/";

void expect_stop(const measure::StepRun& r, const SafetyStep* previous, const std::string& reason) {
    try {
        check_safety_step(r, 1.0, 5.0, kRails, previous);
        FAIL() << "expected a stop: " << reason;
    } catch (const std::runtime_error& e) {
        EXPECT_NE(std::string(e.what()).find(reason), std::string::npos) << e.what();
        EXPECT_NE(std::string(e.what()).find("safety step of 1 V"), std::string::npos) << e.what();
    }
}

TEST(CommissionSafety, AStepThatMovesGivesItsGain) {
    const SafetyStep s = check_safety_step(record(10.0, 13.0, 0.01), 1.0, 5.0, kRails, nullptr);
    EXPECT_DOUBLE_EQ(s.gain_um_per_V, 3.0);
    EXPECT_NEAR(s.noise_um, 0.01, 1e-12);
}

TEST(CommissionSafety, EachStopNamesItsReason) {
    expect_stop(record(10.0, 10.02, 0.01), nullptr, "does not respond");
    expect_stop(record(10.0, 50.0, 0.0), nullptr, "at its rail");
    // Noise that dips below the range's edge is not a rail (it does not
    // repeat its extreme value).
    measure::StepRun near_edge = record(0.0, 3.0, 0.0);
    for (std::size_t i = 0; i < near_edge.y_um.size(); ++i) near_edge.y_um[i] += 0.01 * std::sin(0.7 * static_cast<double>(i));
    EXPECT_NO_THROW(check_safety_step(near_edge, 1.0, 5.0, kRails, nullptr));
    measure::StepRun tripped = record(10.0, 13.0, 0.0);
    tripped.trip = "slew";
    expect_stop(tripped, nullptr, "limiter tripped");
    SafetyStep previous;
    previous.gain_um_per_V = 3.0;
    expect_stop(record(10.0, 15.0, 0.01), &previous, "does not match the previous step");  // 5 um/V after 3
    expect_stop(record(10.0, 7.0, 0.01), &previous, "does not match the previous step");   // the sign flipped
    EXPECT_NO_THROW(check_safety_step(record(10.0, 13.3, 0.01), 1.0, 5.0, kRails, &previous));
}

TEST(CommissionSafety, AStepUpReadAsAMoveDownIsAReversedSensor) {
    // The first step: any negative gain, small or large, stops there.
    for (const double gain : {-0.37, -1.39, -4.2, -12.0}) {
        expect_stop(record(20.0, 20.0 + gain, 0.01), nullptr, "the sensor's sign is reversed");
        expect_stop(record(20.0, 20.0 + gain, 0.01), nullptr, "flip the sign of the sensor's gain");
    }
    // A later step's flip is a mismatch with the previous step.
    SafetyStep previous;
    previous.gain_um_per_V = 1.7;
    expect_stop(record(20.0, 18.4, 0.01), &previous, "does not match the previous step");
}

TEST(CommissionSafety, AnOutputThatStopsGrowingIsARail) {
    // The previous step of 0.4 V from 5 V moved 2.6 um/V; a larger step with
    // half the gain or less (same sign) saturated between 5.4 V and 6 V.
    SafetyStep previous;
    previous.step_V = 0.4;
    previous.gain_um_per_V = 2.6;
    for (const double gain : {0.1, 0.6, 1.1, 1.25}) {
        expect_stop(record(20.0, 20.0 + gain, 0.01), &previous, "the output stops growing");
        expect_stop(record(20.0, 20.0 + gain, 0.01), &previous, "saturates between 5.4 V and 6 V");
    }
    // More than 1.5x is a mismatch, not a rail; just above half passes.
    expect_stop(record(20.0, 24.0, 0.01), &previous, "does not match the previous step");
    EXPECT_NO_THROW(check_safety_step(record(20.0, 21.4, 0.01), 1.0, 5.0, kRails, &previous));
}

TEST(Commission, Ahmad2020FromMeasurementsAlone) {
    const sim::Scenario s = sim::load_scenario(kConfigs + "ahmad2020.json");
    CommissionRequest r;
    r.range_um = 12.0;
    SimStage stage(s);
    const Commissioning c = commission(stage, r);
    ASSERT_GE(c.chosen, 0);
    const Candidate& k = c.candidates[static_cast<std::size_t>(c.chosen)];
    ASSERT_TRUE(k.passes && k.measured.phase_margin);
    EXPECT_GE(k.measured.phase_margin->value, 45.0);
    EXPECT_LE(k.measured.max_sensitivity, 2.0);
    // The safety steps measure the stage's small-signal gain, 2.8 um/V.
    EXPECT_NEAR(c.gain_um_per_V, 2.8, 0.2);
    ASSERT_TRUE(k.predicted.has_value());
    // The loop about mid-span is fitted by a PI model within 1 % (NRMSE)
    // and the chosen controller carries its inverse: on this stage it
    // predicts better than feedback alone.
    ASSERT_TRUE(c.hysteresis.has_value()) << c.hysteresis_note;
    EXPECT_LT(c.hysteresis->nrmse_percent, 1.0);
    EXPECT_TRUE(k.feedforward.has_value()) << k.name;
    EXPECT_TRUE(k.prefilter.has_value()) << k.name;  // the 1 kHz mode is notched out of the reference
    // Verified on the stage: the 10 Hz triangle over half the range first,
    // then the whole range at 1 Hz, 10 Hz and a tenth of the bandwidth.
    EXPECT_TRUE(c.verified()) << c.verification_failure;
    ASSERT_EQ(c.verification.size(), 4u);
    EXPECT_EQ(c.verification[0].request.frequency_Hz, 10.0);
    EXPECT_EQ(c.verification[0].request.range_um, 6.0);
    EXPECT_LT(c.verification[0].measured.e_max_pct, 1.5);
    // The closed loop's response on the stage agrees with the bandwidth the
    // open-loop lines give within 20 % (the hysteresis's slope differs with
    // the amplitude), and sets the last triangle.
    ASSERT_TRUE(c.closed_frf.has_value());
    EXPECT_NEAR(c.measured_bandwidth_Hz, c.bandwidth_Hz, 0.2 * c.bandwidth_Hz);
    EXPECT_NEAR(c.verification[3].request.frequency_Hz, 0.1 * c.measured_bandwidth_Hz, 1e-12);
    // The stage is centred at mid-span (its displacement at 5 V).
    EXPECT_NEAR(c.centre_um, 5.0 * 2.8, 2.0);

    // The written scenario: the identified stage with the controller as
    // its case, which `sim` runs.
    const sim::Scenario id = sim::parse_scenario(commissioned_scenario(c), ".");
    EXPECT_EQ(id.rate_Hz, s.rate_Hz);
    EXPECT_NO_THROW(id.find_case("commissioned"));
    EXPECT_EQ(id.plant.hysteresis.kind, "pi");  // the fitted model
    EXPECT_EQ(id.nominal_um_per_V, c.gain_um_per_V);
}

// The XYZ flexure's z alone: its 4 kHz mode (zeta 0.03) sits at the top of
// the 20 kHz loop's measured band (rate / 5 = 4 kHz). At the default target
// (1 kHz) every candidate passes the margins on the lines yet keeps |L| > 1
// at the band's top, and on the stage the loop rang at the mode (e_max
// 251 %). Such a candidate is refused; the target is lowered until one
// keeps |L| <= 0.5 there, and that one verifies.
TEST(Commission, AModeAtTheBandsEdgeIsNotCrossedBlind) {
    const sim::Scenario s = sim::axis_alone(sim::load_scenario(kConfigs + "stages/xyz_flexure.json"), 2);
    CommissionRequest r;
    r.range_um = 10.0;
    SimStage stage(s);
    const Commissioning c = commission(stage, r);
    ASSERT_GE(c.chosen, 0);
    EXPECT_LT(c.target_bandwidth_Hz, 1000.0);
    const Candidate& k = c.candidates[static_cast<std::size_t>(c.chosen)];
    const double top_Hz = k.measured.f_Hz.back();
    for (std::size_t i = 0; i < k.measured.f_Hz.size(); ++i)
        if (k.measured.f_Hz[i] >= 0.95 * top_Hz) {
            EXPECT_LE(std::abs(k.measured.loop[i]), kMaxLoopGainAtBandEdge) << k.measured.f_Hz[i] << " Hz";
        }
    bool refused_at_edge = false;
    for (const std::string& line : c.log)
        refused_at_edge = refused_at_edge || line.find("at the measured band's top") != std::string::npos;
    EXPECT_TRUE(refused_at_edge);
    EXPECT_TRUE(c.verified()) << c.verification_failure;
    // The closed-loop response holds where the check's triangle stopped,
    // inside the reach, as a board does. Held at the bias's displacement on
    // the scenario's mean slope (50 um, beyond z's reach), the command sat
    // at its limit and |T| read 0 dB over the whole band.
    ASSERT_TRUE(c.closed_frf.has_value());
    EXPECT_EQ(c.closed_frf->clipped_samples, 0u);
    EXPECT_NEAR(c.measured_bandwidth_Hz, c.bandwidth_Hz, 0.2 * c.bandwidth_Hz);
}

// A simulated stage mirrors a board: a closed-loop response measured after
// a triangle holds where that triangle stopped, its minimum (a board's
// triangle stops by itself there and its loop holds it), unless the request
// names a setpoint. Bit for bit: the same run with the minimum named.
TEST(CommissionSimStage, AClosedLoopResponseHoldsWhereTheTriangleStopped) {
    const sim::Scenario s = sim::load_scenario(kConfigs + "ahmad2020.json");
    Controller k;  // a lag at 1 Hz crossing over at about 50 Hz on the mean slope
    k.feedback.poles = {-2.0 * std::numbers::pi};
    k.feedback.gain = 2.0 * std::numbers::pi * 50.0 / s.command_um_per_V();
    SimStage unnamed(s), named(s);
    const measure::MeasureBounds b = unnamed.bounds();
    const TrackRequest t{10.0, 6.0, 0.5 * (b.closed_range.min_um + b.closed_range.max_um)};
    unnamed.track(k, t);
    named.track(k, t);
    measure::FrfRequest q;
    q.from_Hz = 100.0;
    q.to_Hz = 1000.0;
    q.amplitude_V = 0.05;
    q.closed = true;
    q.periods = 2;
    const measure::FrfRun held = unnamed.frf(q);
    q.setpoint_um = t.centre_um - 0.5 * t.range_um;
    EXPECT_EQ(held.log_hash, named.frf(q).log_hash);
    q.setpoint_um = t.centre_um;
    SimStage elsewhere(s);
    elsewhere.track(k, t);
    EXPECT_NE(held.log_hash, elsewhere.frf(q).log_hash);
}

TEST(Commission, TheSeriesInverseIsMeasuredThroughTheLoop) {
    // Ahmad2020's stage: the loading curve's slope doubles over the loop, so
    // the candidates are also offered with the inverse in series, and the
    // stage is measured through it in closed loop before they are checked.
    const sim::Scenario s = sim::load_scenario(kConfigs + "ahmad2020.json");
    CommissionRequest r;
    r.range_um = 12.0;
    SimStage stage(s);
    const Commissioning c = commission(stage, r);
    ASSERT_TRUE(c.hysteresis.has_value());
    ASSERT_GT(c.slope_spread, kStrongHysteresisSpread);
    ASSERT_TRUE(c.through_inverse.has_value());
    const ThroughInverse& t = *c.through_inverse;
    ASSERT_TRUE(t.frf.has_value());
    EXPECT_EQ(t.probe, "robust + PI inverse in series");
    ASSERT_GE(t.f_Hz.size(), 3u) << t.note;
    // Reference: the small signal the closed loop puts through the inverse
    // moves none of its plays, so its gain is 1 / p0, the fitted loading
    // curve's first slope, and the stage through it over the unit-gain model
    // is the fit's DC gain / p0, real. 2 % and 2 deg: the closed-loop
    // estimate's noise on the lines used (observed 0.01 % here, 1 % on
    // Janaideh2016's stage).
    const ModelFit& fit = c.fits[static_cast<std::size_t>(c.chosen_fit)];
    const double want = fit.dc_gain_um_per_V / c.hysteresis->slopes.front();
    EXPECT_NEAR(t.gain_magnitude, want, 0.02 * want);
    EXPECT_NEAR(t.gain_phase_deg, 0.0, 2.0);
    // Every series candidate that passed is checked again: before, as
    // designed on the unit-gain model, its loop through the inverse is the
    // probe's as the closed loop measured it directly (max |S| within 10 %:
    // the median gain against each line's, and two runs' noise); after
    // dividing by the measured gain it passes the checks.
    ASSERT_FALSE(t.before.empty());
    EXPECT_EQ(t.before.front().first, t.probe);
    EXPECT_NEAR(t.before.front().second.max_sensitivity, t.probe_max_sensitivity, 0.1 * t.probe_max_sensitivity);
    for (const auto& [name, before] : t.before) {
        bool found = false;
        for (const Candidate& k : c.candidates)
            if (k.name == name) {
                found = true;
                EXPECT_TRUE(k.series);
                if (k.passes) {
                    EXPECT_LE(k.measured.max_sensitivity, 2.0) << name;
                }
                // The loop shape as designed: the measured gain (its phase
                // is within 2 deg of 0) times the divided controller is the
                // feedback-only candidate's loop on the open-loop lines, to
                // 1 % in max |S|.
                const std::string base = name.substr(0, name.find(" + PI inverse in series"));
                for (const Candidate& b : c.candidates) {
                    if (b.name == base) {
                        EXPECT_NEAR(k.measured.max_sensitivity, b.measured.max_sensitivity,
                                    0.01 * b.measured.max_sensitivity) << name;
                    }
                }
            }
        EXPECT_TRUE(found) << name;
    }
}

TEST(Commission, BandwidthIsWhereTFallsBelowMinus3dB) {
    // T = 1 / (1 + s/wc): |T| = 1/sqrt(2) exactly at fc = 500 Hz. Lines at 20
    // per decade: the interpolation between the two around fc is within 1 %
    // (|T| is smooth there: its log-log slope changes by < 0.3 over a line).
    std::vector<double> f;
    std::vector<design::cplx> t;
    for (double x = 10.0; x < 10000.0; x *= std::pow(10.0, 1.0 / 20.0)) {
        f.push_back(x);
        t.push_back(1.0 / (1.0 + design::cplx(0.0, x / 500.0)));
    }
    EXPECT_NEAR(bandwidth_Hz(f, t), 500.0, 5.0);
    EXPECT_EQ(bandwidth_Hz({10.0, 20.0}, {design::cplx(1.0), design::cplx(0.9)}), 0.0);  // stays above
    EXPECT_EQ(bandwidth_Hz({10.0, 20.0}, {design::cplx(0.5), design::cplx(0.4)}), 10.0);  // starts below
}

TEST(Commission, ReferencePreFilterNotchesTheTwoLowestLightlyDampedModes) {
    // Modes at 100 Hz (ζ 0.01), 300 Hz (ζ 0.05), 500 Hz (ζ 0.02), 50 Hz (ζ 0.5)
    // and 5 kHz (ζ 0.01, beyond to_Hz = 2 kHz).
    auto pair = [](double f_Hz, double zeta) {
        const double w = 2.0 * std::numbers::pi * f_Hz;
        return design::cplx(-zeta * w, w * std::sqrt(1.0 - zeta * zeta));
    };
    design::Zpk g{{}, {}, 1.0, 0.0};
    for (const auto& [f, z] : std::vector<std::pair<double, double>>{{300, 0.05}, {100, 0.01}, {500, 0.02}, {50, 0.5}, {5000, 0.01}}) {
        g.poles.push_back(pair(f, z));
        g.poles.push_back(std::conj(pair(f, z)));
    }
    const std::optional<design::Zpk> f = reference_prefilter(g, 2000.0);
    ASSERT_TRUE(f.has_value());
    ASSERT_EQ(f->zeros.size(), 4u);
    ASSERT_EQ(f->poles.size(), 4u);
    EXPECT_EQ(f->zeros[0], pair(100, 0.01));
    EXPECT_EQ(f->zeros[2], pair(300, 0.05));
    EXPECT_NEAR(std::abs(f->poles[0] - pair(100, 0.7)), 0.0, 1e-9 * std::abs(f->poles[0]));
    EXPECT_NEAR(std::abs(f->poles[2] - pair(300, 0.7)), 0.0, 1e-9 * std::abs(f->poles[2]));
    EXPECT_NEAR(design::dc_gain(*f), 1.0, 1e-12);
    // |F| at the notched mode: its damping over the pre-filter's, 0.01 / 0.7 (analytic, second order).
    const double w = 2.0 * std::numbers::pi * 100.0;
    const double at_mode = std::abs(design::evaluate(*f, design::cplx(0.0, w)));
    const double second = std::abs(design::evaluate(design::Zpk{{f->zeros[2], f->zeros[3]}, {f->poles[2], f->poles[3]}, 1.0, 0.0}, design::cplx(0.0, w)));
    EXPECT_NEAR(at_mode / second, 0.01 / 0.7, 1e-3);
    design::Zpk well_damped{{}, {pair(100, 0.5), std::conj(pair(100, 0.5))}, 1.0, 0.0};
    EXPECT_FALSE(reference_prefilter(well_damped, 2000.0).has_value());
}

// A stage that tracks far worse than predicted (the model misses something):
// the verification fails and says which run.
class BadTracker : public SimStage {
public:
    using SimStage::SimStage;
    TrackingRun track(const Controller& k, const TrackRequest& t) override {
        TrackingRun r = SimStage::track(k, t);
        r.e_max_pct = 50.0;
        return r;
    }
};

TEST(Commission, AStageThatDoesNotTrackAsPredictedFailsTheVerification) {
    CommissionRequest r;
    r.range_um = 12.0;
    BadTracker stage(sim::load_scenario(kConfigs + "ahmad2020.json"));
    const Commissioning c = commission(stage, r);
    ASSERT_GE(c.chosen, 0);
    EXPECT_FALSE(c.verified());
    EXPECT_NE(c.verification_failure.find("10 Hz triangle over 6 um: e_max 50 %"), std::string::npos)
        << c.verification_failure;
}

TEST(Commission, RequestsBeyondTheStageAreRefusedBeforeAnythingMoves) {
    const sim::Scenario s = sim::load_scenario(kConfigs + "ahmad2020.json");
    CommissionRequest r;
    r.range_um = 1000.0;
    SimStage stage(s);
    EXPECT_THROW(commission(stage, r), std::invalid_argument);
    r.range_um = 12.0;
    r.target_bandwidth_Hz = 4000.0;  // the measurement reaches 2 kHz at 10 kHz
    try {
        commission(stage, r);
        FAIL() << "a bandwidth above the measurement";
    } catch (const std::invalid_argument& e) {
        EXPECT_NE(std::string(e.what()).find("--target-bandwidth-hz"), std::string::npos);
    }
}

}  // namespace
}  // namespace piezoloop::commission
