// Shan2012's PI structures (docs/models.md, 'Prandtl–Ishlinskii model',
// 'Analytic PI inverse') expressed as PiModel so they run on
// the same operator bank.
//
// Forward (eq. 4–5): f = g0 u + g1, v = f + sum_j d(gamma_j) F_{gamma_j}[f],
//   gamma_j = rho j, d(gamma) = lambda exp(-delta gamma)          -> p0 = 1.
// Fitted inverse (eq. 22–23): h = g0' v + g1',
//   Pbar_j[k] = max(-h - gamma'_j, min(-h + gamma'_j, Pbar_j[k-1])),
//   u = h + sum_j d'(gamma'_j) Pbar_j.
// Pbar_j is the play of q = -h, so u = -q + sum_j d'_j F[q]: a PiModel with
// input gain -g0', offset -g1', p0 = -1 and weights d'_j. It is a fitted, not
// an analytic, inverse and is implemented as published.
#pragma once

#include "piezoloop/pi_model.hpp"

namespace piezoloop {

struct GeneralizedPi {
    double g0 = 1.0, g1 = 0.0;  // affine input map
    double lambda = 0.0;        // density scale
    double delta = 0.0;         // density exponent: d(gamma) = lambda exp(-delta gamma)
    double rho = 0.0;           // threshold spacing: gamma_j = rho j, j = 1..count
    int count = 0;
};

// Published sets (docs/models.md, 'Shan2012'). The forward set does not state its operator
// count; 8 matches the published inverse (j = 1..8).
inline constexpr GeneralizedPi kShan2012Forward{0.8331, 0.0677, 0.0211, -5.0194, 0.1079, 8};
inline constexpr GeneralizedPi kShan2012Inverse{1.1354, -0.3109, 0.0211, -1.813, 0.527, 8};

constexpr Status validate(const GeneralizedPi& g) {
    if (!is_finite(g.g0) || g.g0 == 0.0) return error("g0", "must be finite and non-zero");
    if (!is_finite(g.g1)) return error("g1", "must be finite");
    if (!is_finite(g.lambda)) return error("lambda", "must be finite");
    if (!is_finite(g.delta) || g.delta < -60.0 || g.delta > 60.0)
        return error("delta", "must be in [-60, 60]");
    if (!is_finite(g.rho) || !(g.rho > 0.0)) return error("rho", "must be finite and > 0");
    if (g.count < 1 || g.count > kMaxPlayOperators) return error("count", "must be in [1, 16]");
    return ok_status();
}

constexpr double density(const GeneralizedPi& g, double gamma) {
    return g.lambda * det_exp(-g.delta * gamma);
}

// sign = +1: the forward model; sign = -1: the inverse structure (q = -h).
constexpr Status shan_model(const GeneralizedPi& g, float sign, PiModel& out) {
    if (const Status s = validate(g); !s.ok()) return s;
    PiModel m{};
    m.input_gain = sign * static_cast<float>(g.g0);
    m.input_offset = sign * static_cast<float>(g.g1);
    m.p0 = sign;
    m.count = g.count;
    for (int j = 1; j <= g.count; ++j) {
        const unsigned i = static_cast<unsigned>(j - 1);
        m.thresholds[i] = static_cast<float>(g.rho * j);
        m.weights[i] = static_cast<float>(density(g, g.rho * j));
    }
    if (const Status s = validate(m); !s.ok()) return s;
    out = m;
    return ok_status();
}

constexpr Status shan_forward_model(const GeneralizedPi& g, PiModel& out) {
    return shan_model(g, 1.0f, out);
}
constexpr Status shan_inverse_model(const GeneralizedPi& g, PiModel& out) {
    return shan_model(g, -1.0f, out);
}

}  // namespace piezoloop
