// Logarithmic creep of a piezo actuator (docs/models.md, 'Creep'): after a
// step the displacement keeps growing by about p % of the step per decade
// of time, y(t) ~ y0 (1 + (p/100) log10(t / t0)) over t0 < t < t1 (Jung &
// Gweon, Rev. Sci. Instrum. 71 (2000); p ~ 1-3 %).
//
// Realised as a bank of first-order lags on the hysteresis output h, one
// per decade, time constants tau_k = from_s * 10^k, k = 0..K with
// to_s = from_s * 10^K:
//   out = h + (p/100) * sum_k w_k lag_k(h)
// A unit step then gives out(t) = 1 + (p/100) sum_k w_k (1 - e^{-t/tau_k}).
// On an endless one-per-decade grid with w_k = 1, the average slope of
// sum_k (1 - e^{-t/tau_k}) per decade of t is exactly 1 (sum of
// x e^{-x} over a log grid of spacing ln 10 averages 1/ln 10), and the
// increase over any whole decade is 1 within 1e-4; the instantaneous slope
// ripples by +-12 % within a decade. The bank ends at to_s, so the last
// lag's weight makes up for the missing ones above it: it is chosen so the
// increase over the last decade [to_s/10, to_s] is exactly 1 (w_K ~ 1.18).
// Every whole decade from from_s to to_s then grows by p % of the step
// within 0.6 % of p (tests/common/test_creep.cpp).
//
// Float without libm: the coefficients come from det_exp at configure time.
// A slow lag updated every sample would lose its increments to float
// rounding (1 - e^{-1/(rate tau)} is 5e-7 for 100 s at 20 kHz, below the
// state's relative ulp), so lag k is updated every n_k samples, n_k the
// largest whole number with n_k <= rate tau_k / 100, and holds its value in
// between: its step response at the update times is exactly the continuous
// lag's, 1 - e^{-m n_k / (rate tau_k)} after m updates, and the hold is at
// most 1 % of tau_k late.
#pragma once

#include <array>
#include <cstdint>

#include "piezoloop/det_math.hpp"
#include "piezoloop/status.hpp"

namespace piezoloop {

inline constexpr int kMaxCreepLags = 9;  // from_s to to_s spans at most 8 decades

struct CreepConfig {
    float percent_per_decade = 0.0f;  // 0: no creep; else in (0, 20]
    float from_s = 0.0f;              // first decade's time constant, > 0
    float to_s = 0.0f;                // from_s * 10^K, K = 1..8
    bool operator==(const CreepConfig&) const = default;
};

// The bank's lags as numbers, in double: the float bank and the double
// fidelity of the simulator (host/sim/stage_double.cpp) both build on them.
struct CreepLags {
    int count = 0;                               // K + 1
    std::array<double, kMaxCreepLags> tau_s{};   // from_s * 10^k
    std::array<double, kMaxCreepLags> weight{};  // 1, ..., 1, w_K
};

// Checks the config and works out the lags; count 0 when creep is off.
constexpr Status creep_lags(const CreepConfig& c, CreepLags& out) {
    out = CreepLags{};
    if (!is_finite(c.percent_per_decade) || c.percent_per_decade < 0.0f || c.percent_per_decade > 20.0f)
        return error("percent_per_decade", "must be finite and in [0, 20] (0: no creep)");
    if (c.percent_per_decade == 0.0f) return ok_status();
    if (!is_finite(c.from_s) || !(c.from_s >= 1e-4f) || !(c.from_s <= 1e4f))
        return error("from_s", "must be in [1e-4, 1e4] s");
    if (!is_finite(c.to_s)) return error("to_s", "must be from_s * 10^K, K = 1..8");
    const double from = c.from_s, to = c.to_s;
    int k = 0;
    double tau = from;
    while (k < kMaxCreepLags - 1 && tau * 10.0 <= to * (1.0 + 1e-4)) {
        tau *= 10.0;
        ++k;
    }
    // to_s must be a whole number of decades above from_s (0.01 % slack for
    // the float rounding of e.g. 0.01 and 100).
    if (k < 1 || tau < to * (1.0 - 1e-4) || tau > to * (1.0 + 1e-4))
        return error("to_s", "must be from_s * 10^K, K = 1..8");
    out.count = k + 1;
    tau = from;
    for (int i = 0; i <= k; ++i) {
        out.tau_s[static_cast<std::size_t>(i)] = tau;
        out.weight[static_cast<std::size_t>(i)] = 1.0;
        tau *= 10.0;
    }
    // The last weight: the increase of sum_k w_k (1 - e^{-t/tau_k}) from
    // to/10 to to is 1. The lags below the last contribute
    // sum_{k<K} (e^{-to/(10 tau_k)} - e^{-to/tau_k}); the last
    // w_K (e^{-0.1} - e^{-1}).
    const double t_a = out.tau_s[static_cast<std::size_t>(k)] / 10.0, t_b = out.tau_s[static_cast<std::size_t>(k)];
    double below = 0.0;
    for (int i = 0; i < k; ++i) {
        const double ti = out.tau_s[static_cast<std::size_t>(i)];
        below += det_exp(-t_a / ti) - det_exp(-t_b / ti);
    }
    out.weight[static_cast<std::size_t>(k)] = (1.0 - below) / (det_exp(-0.1) - det_exp(-1.0));
    return ok_status();
}

// The bank at a sample rate, in float (see the top of the file).
class CreepBank {
public:
    Status configure(const CreepConfig& c, float rate_Hz) {
        CreepLags lags;
        if (const Status s = creep_lags(c, lags); !s.ok()) return s;
        const double rate = rate_Hz;
        for (int i = 0; i < lags.count; ++i) {
            const std::size_t k = static_cast<std::size_t>(i);
            const double samples_per_tau = rate * lags.tau_s[k];
            // tau_k >= 1e-4 s: at a rate below 1 MHz the fastest lag can
            // have fewer than 100 samples per tau; it then updates every
            // sample (n = 1), which needs rate tau >= 2 for a stable, not
            // overshooting lag.
            if (!(samples_per_tau >= 2.0)) return error("from_s", "must be at least 2 samples (2 / rate)");
            if (samples_per_tau > 4.0e9) return error("to_s", "must be below 4e9 samples (4e9 / rate)");
            // (1 + 1e-6: 0.01 s as a float is a hair below 0.01, and 200
            // samples per tau should update every 2, not every 1.)
            double n = static_cast<double>(static_cast<uint32_t>(samples_per_tau / 100.0 * (1.0 + 1e-6)));
            if (n < 1.0) n = 1.0;
            period_[k] = static_cast<uint32_t>(n);
            gain_[k] = static_cast<float>(1.0 - det_exp(-n / samples_per_tau));
            scale_[k] = static_cast<float>(static_cast<double>(c.percent_per_decade) / 100.0 * lags.weight[k]);
        }
        count_ = lags.count;
        reset();
        return ok_status();
    }
    bool enabled() const { return count_ > 0; }

    void reset() {
        state_.fill(0.0f);
        counter_.fill(0u);
        creep_um_ = 0.0f;
    }

    // One sample: the hysteresis output in, it plus its creep out.
    float apply(float h) {
        if (count_ == 0) return h;
        bool updated = false;
        for (int i = 0; i < count_; ++i) {
            const std::size_t k = static_cast<std::size_t>(i);
            if (++counter_[k] < period_[k]) continue;
            counter_[k] = 0u;
            state_[k] = state_[k] + gain_[k] * (h - state_[k]);
            updated = true;
        }
        if (updated) {
            float sum = 0.0f;
            for (int i = 0; i < count_; ++i)
                sum = sum + scale_[static_cast<std::size_t>(i)] * state_[static_cast<std::size_t>(i)];
            creep_um_ = sum;
        }
        return h + creep_um_;
    }

    // The creep alone (what apply() added), last sample.
    float creep_um() const { return creep_um_; }
    // Lag k's update period in samples and its gain per update (1 - e^{-n/(rate tau)}).
    uint32_t period(int k) const { return period_[static_cast<std::size_t>(k)]; }
    float gain(int k) const { return gain_[static_cast<std::size_t>(k)]; }
    int count() const { return count_; }

private:
    int count_ = 0;
    std::array<uint32_t, kMaxCreepLags> period_{};
    std::array<float, kMaxCreepLags> gain_{};   // per update
    std::array<float, kMaxCreepLags> scale_{};  // (p / 100) w_k
    std::array<uint32_t, kMaxCreepLags> counter_{};
    std::array<float, kMaxCreepLags> state_{};
    float creep_um_ = 0.0f;
};

}  // namespace piezoloop
