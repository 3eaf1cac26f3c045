// Dahl parameter fit (host/ident/dahl_fit.hpp).
// References: (1) the model's ODE integrated by classical RK4 along a
// prescribed displacement path gives the voltages that produce it; the
// double-precision plant port must return that path. (2) The core's float
// DahlActuator on the same voltages. (3) Recovery of known parameters from
// loops simulated with seeded noise, judged against the fit's own standard
// errors. Data use the published set in the unit convention where it shows
// hysteresis (dahl_params_in_units(kAhmad2020Dahl, 1e-5, 1), see
// test_dahl.cpp), first cycles, and a set with beta1 != 0.
#include <gtest/gtest.h>

#include <cmath>
#include <random>
#include <stdexcept>
#include <string>
#include <vector>

#include "ident/dahl_fit.hpp"
#include "test_support.hpp"

using namespace piezoloop;
using namespace piezoloop::design;
using piezoloop::test::error_of;

namespace {

const DahlParamsD kVisible = DahlParamsD::from(dahl_params_in_units(kAhmad2020Dahl, 1e-5, 1.0));
// beta1 != 0 (H jumps at reversals), as in test_dahl.cpp.
const DahlParamsD kBeta1{0.05, 4e-3, 0.4, 2.0, 1e-3, 0.925};

// Voltage: 0 -> hi, then `cycles` triangles hi -> lo -> hi, `half` samples per branch.
std::vector<double> loops(double hi, double lo, int cycles, int half) {
    std::vector<double> v;
    for (int k = 0; k < half; ++k) v.push_back(hi * k / half);
    for (int c = 0; c < cycles; ++c) {
        for (int k = 0; k < half; ++k) v.push_back(hi - (hi - lo) * k / half);
        for (int k = 0; k < half; ++k) v.push_back(lo + (hi - lo) * k / half);
    }
    v.push_back(hi);
    return v;
}

std::vector<double> noisy(std::vector<double> x, double sigma, unsigned seed) {
    std::mt19937_64 rng(seed);
    std::normal_distribution<double> g(0.0, sigma);
    for (double& v : x) v += g(rng);
    return x;
}

// Voltages that make the plant follow the path xs exactly: z by RK4 on
// dz/dx = A_H(s) z + B_H with 200 sub-steps per sample, v = (x + H)/ga.
std::vector<double> voltages_for_path(const DahlParamsD& p, const std::vector<double>& xs) {
    double z1 = 0, z2 = 0;
    int s = 1;
    std::vector<double> v{(xs[0] + 0.0) / p.ga};
    for (std::size_t k = 1; k < xs.size(); ++k) {
        const double dx = xs[k] - xs[k - 1];
        if (dx != 0) s = dx < 0 ? -1 : 1;
        const double h = dx / 200;
        auto f = [&](double a, double b, double& da, double& db) {
            da = b;
            db = -p.alpha2 * a - p.alpha1 * s * b + p.gamma_a;
        };
        for (int i = 0; i < 200; ++i) {
            double k1a, k1b, k2a, k2b, k3a, k3b, k4a, k4b;
            f(z1, z2, k1a, k1b);
            f(z1 + h / 2 * k1a, z2 + h / 2 * k1b, k2a, k2b);
            f(z1 + h / 2 * k2a, z2 + h / 2 * k2b, k3a, k3b);
            f(z1 + h * k3a, z2 + h * k3b, k4a, k4b);
            z1 += h / 6 * (k1a + 2 * k2a + 2 * k3a + k4a);
            z2 += h / 6 * (k1b + 2 * k2b + 2 * k3b + k4b);
        }
        v.push_back((xs[k] + p.beta2 * z1 + s * p.beta1 * z2) / p.ga);
    }
    return v;
}

TEST(IdentDahl, PlantPortFollowsTheRk4Path) {
    // Displacement triangles 0..35 with reversals. RK4 with step
    // h = 35/400/200: error ~ (rho h)^4 per unit path, below 1e-12 here;
    // the port solves to double rounding, so 1e-8 of the range is loose.
    for (const DahlParamsD& p : {kVisible, kBeta1}) {
        std::vector<double> xs;
        for (int c = 0; c < 3; ++c) {
            for (int k = 0; k < 400; ++k) xs.push_back(35.0 * k / 400);
            for (int k = 0; k < 400; ++k) xs.push_back(35.0 - 30.0 * k / 400);
        }
        const std::vector<double> v = voltages_for_path(p, xs);
        const std::vector<double> x = simulate_dahl_plant(p, v);
        for (std::size_t k = 0; k < xs.size(); ++k) ASSERT_NEAR(x[k], xs[k], 35e-8) << p.beta1 << " " << k;
    }
}

TEST(IdentDahl, PlantPortMatchesTheFloatActuator) {
    // The core plant integrates with float trapezoidal sub-steps; test_dahl
    // holds it within ~2e-3 µm of the exact path on 35 µm loops, so the
    // double port (exact per sample) must agree to that.
    for (const DahlParamsD& p : {kVisible, kBeta1}) {
        const std::vector<double> v = loops(40.0, 15.0, 3, 200);
        const std::vector<double> x = simulate_dahl_plant(p, v);
        DahlActuator act;
        ASSERT_TRUE(act.configure(p.to_float()).ok());
        act.reset(static_cast<float>(v[0]));
        for (std::size_t k = 0; k < v.size(); ++k)
            ASSERT_NEAR(act.step(static_cast<float>(v[k])), x[k], 2e-3) << p.beta1 << " " << k;
    }
}

// |estimate - truth| <= 4 standard errors (the fit's Gauss–Newton
// covariance; a 4-sigma miss happens by chance with p ~ 6e-5 per parameter).
void expect_recovered(const DahlFitResult& r, const DahlParamsD& truth, double gamma_a) {
    const double c = truth.gamma_a / gamma_a;  // beta scale under the held gamma_a
    const double want[5] = {truth.alpha1, truth.alpha2, truth.beta1 * c, truth.beta2 * c, truth.ga};
    const double got[5] = {r.params.alpha1, r.params.alpha2, r.params.beta1, r.params.beta2, r.params.ga};
    const char* names[5] = {"alpha1", "alpha2", "beta1", "beta2", "ga"};
    ASSERT_EQ(r.std_errors.size(), 5u);
    for (int j = 0; j < 5; ++j) {
        EXPECT_GT(r.std_errors[j], 0.0) << names[j];
        EXPECT_LE(std::fabs(got[j] - want[j]), 4 * r.std_errors[j]) << names[j] << " got " << got[j] << " want " << want[j];
    }
    EXPECT_EQ(r.params.gamma_a, gamma_a);
}

TEST(IdentDahl, FitsAnOutputOffset) {
    // The same loops read by a sensor with an offset of -100 um.
    const std::vector<double> v = loops(40.0, 15.0, 3, 200);
    const double sigma = 0.005, offset = -100.0;
    std::vector<double> x = noisy(simulate_dahl_plant(kVisible, v), sigma, 1);
    for (double& xv : x) xv += offset;
    DahlFitOptions o;
    o.gamma_a = kVisible.gamma_a;
    o.fit_offset = true;
    const DahlFitResult r = fit_dahl(v, x, o);
    expect_recovered(r, kVisible, o.gamma_a);
    // The offset is the mean residual: its error ~ sigma / sqrt(1401) plus
    // what the parameters' errors shift; 4 sigma = 20 nm covers both.
    EXPECT_NEAR(r.offset, offset, 4 * sigma);
    EXPECT_NEAR(r.rms_error, sigma, 0.06 * sigma);
    EXPECT_FALSE(r.poor_fit);
    // Without the offset term the same data is flagged a poor fit or refused.
    o.fit_offset = false;
    try {
        EXPECT_TRUE(fit_dahl(v, x, o).poor_fit);
    } catch (const std::invalid_argument&) {
    }
}

TEST(IdentDahl, RecoversThePublishedSetInTheVisibleConvention) {
    const std::vector<double> v = loops(40.0, 15.0, 3, 200);
    const double sigma = 0.005;  // 5 nm sensor noise
    const std::vector<double> x = noisy(simulate_dahl_plant(kVisible, v), sigma, 1);
    DahlFitOptions o;
    o.gamma_a = kVisible.gamma_a;
    const DahlFitResult r = fit_dahl(v, x, o);
    expect_recovered(r, kVisible, o.gamma_a);
    // With 5 nm noise the standard errors are ~1e-4 of the values: the
    // recovered set is also within 0.1 % (alpha1, alpha2, beta2, ga).
    EXPECT_NEAR(r.params.alpha1, kVisible.alpha1, 1e-3 * kVisible.alpha1);
    EXPECT_NEAR(r.params.alpha2, kVisible.alpha2, 1e-3 * kVisible.alpha2);
    EXPECT_NEAR(r.params.beta2, kVisible.beta2, 1e-3 * kVisible.beta2);
    EXPECT_NEAR(r.params.ga, kVisible.ga, 1e-3 * kVisible.ga);
    // Residual = the noise (1401 samples: relative spread ~2 %; 6 %).
    EXPECT_NEAR(r.rms_error, sigma, 0.06 * sigma);
    EXPECT_GT(r.max_error, 2 * sigma);
    EXPECT_LT(r.nrmse_percent, 0.2);
    EXPECT_LT(r.jacobian_condition, 1e4);
    EXPECT_EQ(r.starts, 3);
    EXPECT_EQ(r.params_float.alpha2, static_cast<float>(r.params.alpha2));
    EXPECT_EQ(r.params_float.gamma_a, static_cast<float>(kVisible.gamma_a));
    EXPECT_TRUE(validate(r.params_float).ok());
}

TEST(IdentDahl, GammaAConventionOnlyRescalesBeta) {
    // (gamma_a, beta) -> (c gamma_a, beta / c) gives the same loops: with
    // gamma_a held at 1 the fit returns the same alpha, ga and beta*gamma_a.
    // Same data and the same scaled problem, but the LM stops where its
    // finite-difference steps no longer improve (~1e-6 relative, ~1e-3 of a
    // standard error): the two optima must agree to 1e-2 standard errors.
    const std::vector<double> v = loops(40.0, 15.0, 3, 200);
    const std::vector<double> x = noisy(simulate_dahl_plant(kVisible, v), 0.005, 1);
    DahlFitOptions held;
    held.gamma_a = kVisible.gamma_a;
    DahlFitOptions unit;
    unit.gamma_a = 1.0;
    const DahlFitResult a = fit_dahl(v, x, held), b = fit_dahl(v, x, unit);
    expect_recovered(b, kVisible, 1.0);
    EXPECT_NEAR(b.params.alpha1, a.params.alpha1, 1e-2 * a.std_errors[0]);
    EXPECT_NEAR(b.params.alpha2, a.params.alpha2, 1e-2 * a.std_errors[1]);
    EXPECT_NEAR(b.params.ga, a.params.ga, 1e-2 * a.std_errors[4]);
    EXPECT_NEAR(b.beta2_gamma_a, a.beta2_gamma_a, 1e-2 * a.std_errors[3] * a.params.gamma_a);
    EXPECT_NEAR(b.params.beta2, kVisible.beta2 * kVisible.gamma_a, 4 * b.std_errors[3]);
}

TEST(IdentDahl, ConvergesFromAGivenStart) {
    // Start 50 % / 30 % / 20 % / 10 % off: the same optimum as the grid start
    // (to 1e-2 standard errors, the LM stopping argument above).
    const std::vector<double> v = loops(40.0, 15.0, 3, 200);
    const std::vector<double> x = noisy(simulate_dahl_plant(kVisible, v), 0.005, 1);
    DahlFitOptions o;
    o.gamma_a = kVisible.gamma_a;
    const DahlFitResult grid = fit_dahl(v, x, o);
    DahlParamsD start = kVisible;
    start.alpha1 *= 1.5;
    start.alpha2 *= 0.7;
    start.beta2 *= 1.2;
    start.ga *= 0.9;
    o.start = start;
    const DahlFitResult r = fit_dahl(v, x, o);
    EXPECT_EQ(r.starts, 1);
    for (int j = 0; j < 5; ++j) {
        const double got[5] = {r.params.alpha1, r.params.alpha2, r.params.beta1, r.params.beta2, r.params.ga};
        const double want[5] = {grid.params.alpha1, grid.params.alpha2, grid.params.beta1, grid.params.beta2,
                                grid.params.ga};
        EXPECT_NEAR(got[j], want[j], 1e-2 * grid.std_errors[j]) << j;
    }
}

TEST(IdentDahl, ReportsProgressPerSimulation) {
    // The progress callback (stderr output of `identify dahl`) sees every
    // model simulation, named by its LM run; it does not change the fit.
    const std::vector<double> v = loops(40.0, 15.0, 3, 200);
    const std::vector<double> x = noisy(simulate_dahl_plant(kVisible, v), 0.005, 1);
    DahlFitOptions o;
    o.gamma_a = kVisible.gamma_a;
    const DahlFitResult quiet = fit_dahl(v, x, o);
    int calls = 0;
    std::string last;
    o.progress = [&](const std::string& what) {
        ++calls;
        last = what;
    };
    const DahlFitResult r = fit_dahl(v, x, o);
    EXPECT_GT(calls, 0);
    EXPECT_LE(calls, r.evaluations);
    EXPECT_EQ(last.rfind("LM run ", 0), 0u) << last;
    EXPECT_NE(last.find("model simulations"), std::string::npos) << last;
    EXPECT_EQ(r.params.alpha1, quiet.params.alpha1);
    EXPECT_EQ(r.params.ga, quiet.params.ga);
}

TEST(IdentDahl, RecoversBeta1) {
    const std::vector<double> v = loops(40.0, 0.0, 3, 200);
    const std::vector<double> x = noisy(simulate_dahl_plant(kBeta1, v), 0.005, 2);
    DahlFitOptions o;
    o.gamma_a = kBeta1.gamma_a;
    const DahlFitResult r = fit_dahl(v, x, o);
    expect_recovered(r, kBeta1, o.gamma_a);
    // beta1 is the least determined (its effect decays with the transient):
    // the data pin it to within 25 %.
    EXPECT_NEAR(r.params.beta1, kBeta1.beta1, 0.25 * kBeta1.beta1);
    EXPECT_NEAR(r.rms_error, 0.005, 0.06 * 0.005);
}

// A record that starts mid-loop: the stage rested at 0 V (virgin) and was
// ramped to 20 V before the record, which then runs 20 -> 40 V and three
// 40 <-> 0 V cycles. The Dahl set has a long transient (2/alpha1 = 400 µm of
// path, about 5 branches), so the start matters throughout the record;
// its hysteresis, beta2 gamma_a / alpha2 = 5 µm, is 14 % of the travel.
const DahlParamsD kLongMemory{0.005, 4e-3, 4.0, 20.0, 1e-3, 0.925};

struct MidLoopRecord {
    std::vector<double> v, x;
};

MidLoopRecord mid_loop_record(const DahlParamsD& p, double sigma, unsigned seed) {
    std::vector<double> history;  // the unrecorded warm-up: 0 -> 20 V
    for (int k = 0; k < 100; ++k) history.push_back(20.0 * k / 100);
    std::vector<double> rec;
    for (int k = 0; k < 100; ++k) rec.push_back(20.0 + 20.0 * k / 100);
    for (int c = 0; c < 3; ++c) {
        for (int k = 0; k < 200; ++k) rec.push_back(40.0 - 40.0 * k / 200);
        for (int k = 0; k < 200; ++k) rec.push_back(40.0 * k / 200);
    }
    rec.push_back(40.0);
    std::vector<double> all = history;
    all.insert(all.end(), rec.begin(), rec.end());
    const std::vector<double> x = simulate_dahl_plant(p, all);
    return {rec, noisy(std::vector<double>(x.begin() + 100, x.end()), sigma, seed)};
}

TEST(IdentDahl, PlantFromAVirginVoltageIsTheVirginPlantAfterAStraightMove) {
    // simulate_dahl_plant_from(p, v0, v, first) = the virgin plant on
    // {v0, v[first], v[first + 1], ...} without its first sample: the same
    // port, so equal to rounding (1e-12 of the range).
    const std::vector<double> v = loops(40.0, 0.0, 2, 100);
    for (const DahlParamsD& p : {kBeta1, kLongMemory}) {
        std::vector<double> w{7.0};
        w.insert(w.end(), v.begin() + 150, v.end());
        const std::vector<double> ref = simulate_dahl_plant(p, w);
        const std::vector<double> got = simulate_dahl_plant_from(p, 7.0, v, 150);
        ASSERT_EQ(got.size(), v.size() - 150);
        for (std::size_t k = 0; k < got.size(); ++k) ASSERT_NEAR(got[k], ref[k + 1], 1e-12 * 40.0) << k;
    }
}

TEST(IdentDahl, RecoversASetFromARecordThatStartsMidLoop) {
    const double sigma = 0.005;
    const MidLoopRecord d = mid_loop_record(kLongMemory, sigma, 4);
    DahlFitOptions o;
    o.gamma_a = kLongMemory.gamma_a;
    o.fit_offset = true;
    o.first_fitted = DahlFitOptions::kAutoFirstFitted;
    o.start_state = DahlStartState::kEstimated;
    o.holdout = 0.25;
    const DahlFitResult r = fit_dahl(d.v, d.x, o);
    // The first turning point: the 40 V peak at sample 100.
    EXPECT_EQ(r.first_fitted, 100u);
    EXPECT_EQ(r.validated_from, d.v.size() - d.v.size() / 4);
    // Every parameter and the virgin voltage (0 V) within 4 standard errors.
    expect_recovered(r, kLongMemory, o.gamma_a);
    ASSERT_TRUE(r.virgin_V && r.virgin_V_std_error);
    EXPECT_LE(std::fabs(*r.virgin_V - 0.0), 4.0 * *r.virgin_V_std_error) << *r.virgin_V;
    // With 5 nm noise the errors are small: alpha1 within 2 %, the others
    // within 0.5 %; the residual is the noise, fitted and held out (6 %: the
    // spread of an rms over ~900 samples is ~2.4 %).
    EXPECT_NEAR(r.params.alpha1, kLongMemory.alpha1, 0.02 * kLongMemory.alpha1);
    EXPECT_NEAR(r.params.alpha2, kLongMemory.alpha2, 5e-3 * kLongMemory.alpha2);
    EXPECT_NEAR(r.params.beta2, kLongMemory.beta2, 5e-3 * kLongMemory.beta2);
    EXPECT_NEAR(r.params.ga, kLongMemory.ga, 5e-3 * kLongMemory.ga);
    EXPECT_NEAR(r.rms_error, sigma, 0.06 * sigma);
    EXPECT_EQ(r.validation_samples, d.v.size() / 4);
    EXPECT_NEAR(r.validation_rms_error, sigma, 0.08 * sigma);
    EXPECT_NEAR(r.offset, 0.0, 4 * sigma);
    EXPECT_FALSE(r.poor_fit);

    // From the virgin state at the record's first sample the same data are
    // not described: the fit is refused or misses by far more than the noise.
    o.start_state = DahlStartState::kVirgin;
    o.first_fitted = 0;
    try {
        const DahlFitResult v = fit_dahl(d.v, d.x, o);
        EXPECT_GT(v.rms_error, 10 * sigma);
    } catch (const std::invalid_argument&) {
    }
}

TEST(IdentDahl, RefusesBadWindows) {
    const MidLoopRecord d = mid_loop_record(kLongMemory, 0.0, 1);
    DahlFitOptions o;
    o.gamma_a = kLongMemory.gamma_a;
    o.first_fitted = d.v.size() - 10;
    EXPECT_EQ(error_of([&] { fit_dahl(d.v, d.x, o); }), "v: too short: 10 fitted samples; the Dahl fit needs at least 50");
    o.holdout = 0.5;
    EXPECT_EQ(error_of([&] { fit_dahl(d.v, d.x, o); }).rfind("first_fitted: 1291 is not below the 651 samples before the held-out part", 0), 0u)
        << error_of([&] { fit_dahl(d.v, d.x, o); });
    o.holdout = 0.95;
    EXPECT_EQ(error_of([&] { fit_dahl(d.v, d.x, o); }), "holdout: must be in [0, 0.9]");
    // A monotone input has no turning point for the automatic first sample.
    o.holdout = 0.0;
    o.first_fitted = DahlFitOptions::kAutoFirstFitted;
    std::vector<double> ramp, xr;
    for (int k = 0; k < 200; ++k) ramp.push_back(0.2 * k);
    xr = simulate_dahl_plant(kLongMemory, ramp);
    EXPECT_EQ(error_of([&] { fit_dahl(ramp, xr, o); }).rfind("v: never turns back by more than 1 % of its span", 0), 0u);
}

TEST(IdentDahl, RefusesDataThatCannotIdentifyTheModel) {
    DahlFitOptions o;
    o.gamma_a = kVisible.gamma_a;
    // Loops of 10 mV travel ~1e-4 of the transient length 2/alpha1 = 114 µm:
    // H is then ~beta2 gamma_a x^2/2 and alpha1, alpha2 are not separable.
    const std::vector<double> vt = loops(0.01, 0.0, 3, 200);
    const std::vector<double> xt = noisy(simulate_dahl_plant(kVisible, vt), 1e-6, 3);
    const std::string tiny = error_of([&] { fit_dahl(vt, xt, o); });
    EXPECT_EQ(tiny.rfind("v: the data cannot identify the Dahl parameters", 0), 0u) << tiny;
    EXPECT_NE(tiny.find("alpha"), std::string::npos) << tiny;

    const std::vector<double> v = loops(40.0, 15.0, 1, 100);
    const std::vector<double> x = simulate_dahl_plant(kVisible, v);
    const std::vector<double> flat(v.size(), 3.0);
    EXPECT_EQ(error_of([&] { fit_dahl(flat, x, o); }), "v: no excitation: the voltage is constant");
    EXPECT_EQ(error_of([&] { fit_dahl(v, flat, o); }), "x: the displacement is constant: nothing to identify");
    EXPECT_EQ(error_of([&] { fit_dahl(std::span<const double>(v.data(), 40), std::span<const double>(x.data(), 40), o); }),
              "v: too short: 40 samples; the Dahl fit needs at least 50");
    std::vector<double> xnan = x;
    xnan[7] = NAN;
    EXPECT_EQ(error_of([&] { fit_dahl(v, xnan, o); }), "x: sample 7 is not finite (NaN/Inf)");
    o.input_name = "v_V";
    o.output_name = "x_um";
    EXPECT_EQ(error_of([&] { fit_dahl(v, std::span<const double>(x.data(), 60), o); })
                  .rfind("x_um: has 60 samples but v_V has", 0),
              0u);
    o.gamma_a = 0.0;
    EXPECT_EQ(error_of([&] { fit_dahl(v, x, o); }).rfind("gamma_a: must be finite and non-zero", 0), 0u);
    o.gamma_a = 1.0;
    DahlParamsD bad = kVisible;
    bad.alpha2 = -1.0;
    o.start = bad;
    EXPECT_EQ(error_of([&] { fit_dahl(v, x, o); }).rfind("start: needs", 0), 0u);
}

}  // namespace
