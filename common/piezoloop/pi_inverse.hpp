// Exact analytic inverse of a PI model, docs/models.md, 'Analytic PI inverse' (Janaideh2016 eq. 44–45).
//
// The inverse of a plain PI model (input_gain 1, offset 0) is another PI
// model whose loading curve is the inverse of phi: thresholds z_j = phi(r_j),
// weights g_0 = 1/p0 and g_j = -p_j / (P_j P_{j-1}), where P_j = p0 + sum_{i<=j}
// p_i is the slope of phi after r_j. It exists when every P_j > 0 (monotone
// loading curve); otherwise the offending segment is reported and `inv` is not
// touched. Runs in double, from arrays, without heap: usable on the target.
#pragma once

#include "piezoloop/pi_model.hpp"

namespace piezoloop {

// Builds a plain PiModel from threshold/weight lists as users and papers write
// them (docs/models.md, 'Prandtl–Ishlinskii model'):
//  - with an explicit p0, the lists are the play operators;
//  - without p0 and r_1 == 0, the threshold-0 play is the identity: p0 = p_1;
//  - without p0 and r_1 > 0 (Janaideh2016's 15-operator set), the first
//    operator is taken as the linear term: p0 = p_1 and every remaining
//    threshold is shifted down by r_1.
constexpr Status pi_model_from_lists(const float* thresholds, const float* weights, int n,
                                     const float* p0_or_null, PiModel& out) {
    if (n < 0 || n > kMaxPlayOperators + 1) return error("thresholds", "count must be in [0, 17]");
    PiModel m{};
    int first = 0;
    float shift = 0.0f;
    if (p0_or_null != nullptr) {
        m.p0 = *p0_or_null;
    } else {
        if (n == 0) return error("weights", "needs a linear term: give p0 or at least one operator");
        m.p0 = weights[0];
        shift = thresholds[0];
        first = 1;
    }
    if (n - first > kMaxPlayOperators) return error("thresholds", "at most 16 play operators");
    m.count = n - first;
    for (int j = first; j < n; ++j) {
        const unsigned i = static_cast<unsigned>(j - first);
        m.thresholds[i] = thresholds[j] - shift;
        m.weights[i] = weights[j];
    }
    if (const Status s = validate(m); !s.ok()) return s;
    out = m;
    return ok_status();
}

constexpr Status invert_pi(const PiModel& fwd, PiModel& inv) {
    if (const Status s = validate(fwd); !s.ok()) return s;
    if (fwd.input_gain != 1.0f || fwd.input_offset != 0.0f)
        return error("input_gain", "the analytic inverse needs the plain model (gain 1, offset 0)");
    if (fwd.dead_zones != 0)
        return error("dead_zones", "the analytic inverse needs the plain model (no input dead zones)");
    if (!(fwd.p0 > 0.0f))
        return error("p0", 0, "segment 0: slope p0 must be > 0 for the model to be invertible");
    PiModel out{};
    out.p0 = static_cast<float>(1.0 / fwd.p0);
    out.count = fwd.count;
    double slope_prev = fwd.p0;  // P_{j-1}
    double r_prev = 0.0, z_prev = 0.0;
    for (int j = 0; j < fwd.count; ++j) {
        const unsigned i = static_cast<unsigned>(j);
        const double r = fwd.thresholds[i];
        const double p = fwd.weights[i];
        const double slope = slope_prev + p;  // P_j
        if (!(slope > 0.0))
            return error("weights", j,
                         "loading-curve slope p0 + sum of weights up to this operator is <= 0: "
                         "model not invertible on this segment");
        const double z = z_prev + slope_prev * (r - r_prev);
        out.thresholds[i] = static_cast<float>(z);
        out.weights[i] = static_cast<float>(-p / (slope * slope_prev));
        slope_prev = slope;
        r_prev = r;
        z_prev = z;
    }
    // Thresholds are strictly ascending in exact arithmetic; a float rounding
    // that merges two of them would make a model validate() rejects.
    if (const Status s = validate(out); !s.ok()) return s;
    inv = out;
    return ok_status();
}

}  // namespace piezoloop
