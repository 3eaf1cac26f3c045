// Shared by the axes tests (tests/common/axes/): random valid matrices,
// extreme commands, and the check of the channels' hard limits and slew.
#pragma once

#include <algorithm>
#include <array>
#include <cmath>
#include <cstdint>
#include <limits>
#include <random>
#include <type_traits>

#include "piezoloop/axes/axis_matrix.hpp"
#include "piezoloop/limits.hpp"

namespace piezoloop::test {

template <int N>
AxisMatrix<N> random_valid_matrix(std::mt19937_64& rng) {
    std::uniform_real_distribution<float> wide(-16.0f, 16.0f), coupling(-0.5f, 0.5f);
    std::bernoulli_distribution near_identity(0.5);
    for (;;) {
        AxisMatrix<N> m{};
        const bool near = near_identity(rng);
        for (int i = 0; i < N; ++i)
            for (int j = 0; j < N; ++j) m.m[i][j] = near ? (i == j ? 1.0f : 0.0f) + coupling(rng) : wide(rng);
        if (validate_output_matrix(m).ok()) return m;
    }
}

// The channels' bounds in volts, checked in double: inside the hard range,
// and a step no larger than the hard slew / rate.
template <class T>
double volts(T u, SignalScale s) {
    if constexpr (std::is_same_v<T, float>) return u;
    else return static_cast<double>(u.raw()) / 2147483648.0 * s.full_scale;
}

template <class T, int N>
struct ChannelBounds {
    std::array<HardLimits, N> hard{};
    std::array<SignalScale, N> scale{};
    double rate_Hz = 0.0;
    std::array<double, N> prev{};
    int violations = 0;
    void check(const std::array<T, N>& u) {
        for (int i = 0; i < N; ++i) {
            const double v = volts(u[i], scale[i]);
            const double step = static_cast<double>(hard[i].slew_max_V_per_s) / rate_Hz;
            if (!(v >= hard[i].u_min_V && v <= hard[i].u_max_V) || !(std::fabs(v - prev[i]) <= step)) ++violations;
            prev[i] = v;
        }
    }
};

// An axis command: float with overflowing, huge, denormal and signed-zero
// values among the ordinary ones (no NaN); Q31 with the extremes.
template <class T>
T random_command(std::mt19937_64& rng) {
    if constexpr (std::is_same_v<T, float>) {
        constexpr float kMax = std::numeric_limits<float>::max();
        const float extremes[] = {kMax, -kMax, 1.0e30f, -1.0e30f, 1.0e-40f, -0.0f, 1.0e6f, -1.0e6f};
        std::uniform_int_distribution<int> pick(0, 9);
        const int k = pick(rng);
        if (k < 8 && std::bernoulli_distribution(0.3)(rng)) return extremes[k];
        return std::uniform_real_distribution<float>(-200.0f, 200.0f)(rng);
    } else {
        const int32_t extremes[] = {Q31::kMaxRaw, Q31::kMinRaw, 0, 1, -1};
        if (std::bernoulli_distribution(0.3)(rng)) return Q31::from_raw(extremes[rng() % 5]);
        return Q31::from_raw(static_cast<int32_t>(static_cast<uint32_t>(rng())));
    }
}

}  // namespace piezoloop::test
