// measure/step_response against analytic step responses.
//
// Second order, unit DC gain, 0 < zeta < 1 (Franklin, Powell & Emami-Naeini,
// Feedback Control of Dynamic Systems, §3.3):
//   y(t) = 1 - exp(-zeta wn t) / sqrt(1 - zeta^2) * sin(wd t + acos zeta),
//   wd = wn sqrt(1 - zeta^2); overshoot exp(-pi zeta / sqrt(1 - zeta^2)).
// The 10-90 % rise time and the 2 % settling time have no closed form for a
// general zeta: the test finds them on the analytic y(t) itself (bisection to
// 1e-12 s on the formula, not on samples), so the reference is independent of
// the sampled analysis under test. First order, y = 1 - exp(-t/tau): rise
// tau ln 9 and settling tau ln 50 exactly.
#include "measure/step_response.hpp"

#include <gtest/gtest.h>

#include <cmath>
#include <functional>
#include <numbers>
#include <random>
#include <stdexcept>
#include <vector>

namespace pm = piezoloop::measure;

namespace {

struct SecondOrder {
    double zeta, wn;
    double operator()(double t) const {
        if (t < 0.0) return 0.0;
        const double s = std::sqrt(1.0 - zeta * zeta);
        return 1.0 - std::exp(-zeta * wn * t) / s * std::sin(wn * s * t + std::acos(zeta));
    }
};

// Root of f in [a, b], f(a) and f(b) of opposite signs.
double bisect(const std::function<double(double)>& f, double a, double b) {
    double fa = f(a);
    for (int i = 0; i < 200 && b - a > 1e-13; ++i) {
        const double m = 0.5 * (a + b), fm = f(m);
        if ((fm < 0.0) == (fa < 0.0)) {
            a = m;
            fa = fm;
        } else {
            b = m;
        }
    }
    return 0.5 * (a + b);
}

// First time y reaches `level`: scan on a grid 10x finer than the samples (no
// two crossings of a level are that close here), then bisect.
double first_time(const std::function<double(double)>& y, double level, double t_end, double dt) {
    for (double t = 0.0; t < t_end; t += dt)
        if (y(t + dt) >= level) return bisect([&](double x) { return y(x) - level; }, t, t + dt);
    return NAN;
}

// Last time |y - 1| = band: scan back from the end, then bisect.
double settling_time(const std::function<double(double)>& y, double band, double t_end, double dt) {
    for (double t = t_end; t > 0.0; t -= dt) {
        if (std::fabs(y(t - dt) - 1.0) > band) {
            const double edge = y(t - dt) > 1.0 ? 1.0 + band : 1.0 - band;
            return bisect([&](double x) { return y(x) - edge; }, t - dt, t);
        }
    }
    return 0.0;
}

// y sampled at Ts from t = -pre Ts, scaled to y0 + dy * y(t).
std::vector<double> sample(const std::function<double(double)>& y, double ts, std::size_t pre, std::size_t post,
                           double y0 = 0.0, double dy = 1.0) {
    std::vector<double> v;
    for (std::size_t k = 0; k < pre + post; ++k)
        v.push_back(y0 + dy * y((static_cast<double>(k) - static_cast<double>(pre)) * ts));
    return v;
}

}  // namespace

// Tolerances. Ts = 10 us against periods of 4..20 ms: linear interpolation
// of a crossing errs by about y'' Ts^2 / (8 y'), ~1e-8 s here, so the times
// are checked to 1 % of a sample (1e-7 s), far looser than that error and
// far tighter than the one-sample error an analysis without interpolation
// makes. The overshoot is the sampled peak's: the true peak lies within
// Ts/2 of a sample, where y differs by at most y'' (Ts/2)^2 / 2 ~ wn^2 Ts^2 / 8
// (relative), ~2e-6 for wn = 2 pi 100 rad/s: checked to 1e-3 % (absolute).
// The record runs 20 time constants past the settling time, so the tail the
// final value averages is within exp(-20) of 1: the final value to 1e-7.
TEST(StepResponse, SecondOrderMatchesClosedForms) {
    const double ts = 1e-5;
    for (const double zeta : {0.05, 0.1, 0.3, 0.5, 0.7, 0.9}) {
        const SecondOrder g{zeta, 2.0 * std::numbers::pi * 100.0};
        const double tau = 1.0 / (zeta * g.wn);
        const double t_end = 28.0 * tau;  // settling ~ 4-8 tau, then 20 tau of tail
        const auto y = sample(g, ts, 50, static_cast<std::size_t>(t_end / ts));
        const pm::StepFigures f = pm::analyse_step(y, ts, 50);
        const double os = 100.0 * std::exp(-std::numbers::pi * zeta / std::sqrt(1.0 - zeta * zeta));
        const double rise = first_time(g, 0.9, t_end, ts / 10) - first_time(g, 0.1, t_end, ts / 10);
        const double settle = settling_time(g, 0.02, t_end, ts / 10);
        SCOPED_TRACE("zeta " + std::to_string(zeta));
        EXPECT_NEAR(f.initial, 0.0, 1e-12);
        EXPECT_NEAR(f.final_value, 1.0, 1e-7);
        EXPECT_NEAR(f.overshoot_pct, os, 1e-3);
        EXPECT_NEAR(f.peak_time_s, std::numbers::pi / (g.wn * std::sqrt(1.0 - zeta * zeta)), ts);
        EXPECT_NEAR(f.rise_time_s, rise, 1e-7);
        EXPECT_TRUE(f.settled);
        EXPECT_NEAR(f.settling_time_s, settle, 1e-7);
    }
}

// First order: exact closed forms for every figure, and no overshoot.
TEST(StepResponse, FirstOrderClosedForms) {
    const double ts = 1e-5, tau = 2e-3;
    auto g = [&](double t) { return t < 0.0 ? 0.0 : 1.0 - std::exp(-t / tau); };
    const auto y = sample(g, ts, 10, static_cast<std::size_t>(30 * tau / ts));
    const pm::StepFigures f = pm::analyse_step(y, ts, 10);
    // The tail averaged for the final value sits exp(-27) below 1, so the last
    // samples lie a hair above it: "no overshoot" is to 1e-8 %.
    EXPECT_NEAR(f.overshoot_pct, 0.0, 1e-8);
    EXPECT_NEAR(f.rise_time_s, tau * std::log(9.0), 1e-7);
    EXPECT_NEAR(f.settling_time_s, tau * std::log(50.0), 1e-7);
}

// A downward step from an offset, scaled: the figures are those of the unit
// step (z is normalised by final - initial, whatever its sign).
TEST(StepResponse, DownwardStepFromAnOffset) {
    const double ts = 1e-5;
    const SecondOrder g{0.3, 2.0 * std::numbers::pi * 100.0};
    const std::size_t post = static_cast<std::size_t>(0.15 / ts);
    const pm::StepFigures up = pm::analyse_step(sample(g, ts, 20, post), ts, 20);
    const pm::StepFigures down = pm::analyse_step(sample(g, ts, 20, post, 12.0, -5.0), ts, 20);
    EXPECT_NEAR(down.initial, 12.0, 1e-12);
    EXPECT_NEAR(down.final_value, 7.0, 1e-6);
    EXPECT_NEAR(down.peak, 12.0 - 5.0 * (1.0 + up.overshoot_pct / 100.0), 1e-6);
    EXPECT_NEAR(down.overshoot_pct, up.overshoot_pct, 1e-6);
    EXPECT_NEAR(down.rise_time_s, up.rise_time_s, 1e-9);
    EXPECT_NEAR(down.settling_time_s, up.settling_time_s, 1e-9);
}

// Noise on the record: the initial and final levels are means, so a noise of
// 0.1 % of the step (rms) moves them by about 0.1 % / sqrt(samples averaged);
// overshoot by about the noise's peak (~0.4 % of the step). The settling time
// is taken at the last excursion beyond the band; noise of 0.1 % rms (peaks
// ~0.4 %) adds excursions where the clean response is within ~1.6 % of the
// final value, i.e. at a later extremum of the oscillation: the settling time
// may move later by up to half a damped period (one extremum) or so, and
// earlier only where noise pulls a marginal excursion back into the band
// (checked to a quarter period).
TEST(StepResponse, NoiseMovesTheFiguresLittle) {
    const double ts = 1e-5;
    const SecondOrder g{0.3, 2.0 * std::numbers::pi * 100.0};
    auto clean = sample(g, ts, 1000, static_cast<std::size_t>(0.15 / ts));
    auto noisy = clean;
    std::mt19937 rng(16);
    std::normal_distribution<double> n(0.0, 1e-3);
    for (double& v : noisy) v += n(rng);
    const pm::StepFigures a = pm::analyse_step(clean, ts, 1000), b = pm::analyse_step(noisy, ts, 1000);
    EXPECT_NEAR(b.initial, 0.0, 2e-4);
    EXPECT_NEAR(b.final_value, a.final_value, 1e-4);
    EXPECT_NEAR(b.overshoot_pct, a.overshoot_pct, 0.5);
    EXPECT_NEAR(b.rise_time_s, a.rise_time_s, 2 * ts);
    const double quarter_period = 0.25 * 2.0 * std::numbers::pi / (g.wn * std::sqrt(1.0 - 0.09));
    EXPECT_GT(b.settling_time_s, a.settling_time_s - quarter_period);
    EXPECT_LT(b.settling_time_s, a.settling_time_s + 2.0 * quarter_period + 2 * ts);
}

// A record that ends before the response settles says so.
TEST(StepResponse, UnsettledRecord) {
    const double ts = 1e-5;
    const SecondOrder g{0.05, 2.0 * std::numbers::pi * 100.0};
    const auto y = sample(g, ts, 10, static_cast<std::size_t>(0.0349 / ts));  // ends near a peak
    const pm::StepFigures f = pm::analyse_step(y, ts, 10);
    EXPECT_FALSE(f.settled);
    EXPECT_TRUE(std::isnan(f.settling_time_s));
}

TEST(StepResponse, RefusesWhatCannotDefineAStep) {
    const std::vector<double> flat(100, 1.0), short_rec{0.0, 1.0};
    std::vector<double> with_nan(100, 0.0);
    for (std::size_t k = 10; k < 100; ++k) with_nan[k] = 1.0;
    with_nan[50] = NAN;
    EXPECT_THROW(pm::analyse_step(flat, 1e-3, 10), pm::NoStepResponse);           // final == initial: the stage did not move
    EXPECT_THROW(pm::analyse_step(short_rec, 1e-3, 1), std::invalid_argument);    // one sample after
    EXPECT_THROW(pm::analyse_step(with_nan, 1e-3, 10), std::invalid_argument);    // non-finite
    EXPECT_THROW(pm::analyse_step(with_nan, 1e-3, 0), std::invalid_argument);     // nothing before
    EXPECT_THROW(pm::analyse_step(flat, 0.0, 10), std::invalid_argument);         // no sample period
}
