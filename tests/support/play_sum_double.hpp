// A PI model's play operators and their weighted sum in double, written from
// docs/models.md, 'Prandtl–Ishlinskii model' (not the core's code): the
// tests' reference for PI operators. It takes the play domain's input f; the
// caller applies the model's input map, in the arithmetic it compares with.
#pragma once

#include <algorithm>
#include <array>

#include "piezoloop/pi_model.hpp"

namespace piezoloop::test {

struct PlaySumDouble {
    PiModel m;
    std::array<double, kMaxPlayOperators> w{};  // the play states

    // The states after coming up to t from far below: w_j = t - r_j.
    void ascended_to(double t) {
        for (int j = 0; j < m.count; ++j) w[static_cast<unsigned>(j)] = t - m.thresholds[static_cast<unsigned>(j)];
    }
    double apply(double f) {
        double y = static_cast<double>(m.p0) * f;
        for (int j = 0; j < m.count; ++j) {
            const unsigned i = static_cast<unsigned>(j);
            const double r = m.thresholds[i];
            w[i] = std::max(f - r, std::min(f + r, w[i]));
            y += static_cast<double>(m.weights[i]) * w[i];
        }
        return y;
    }
};

}  // namespace piezoloop::test
