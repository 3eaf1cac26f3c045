// Bilinear (Tustin) transform of one continuous second-order section,
//   H(s) = (b2 s^2 + b1 s + b0) / (a2 s^2 + a1 s + a0),
// with s = K (z - 1)/(z + 1), K = 2 * rate. Closed form, no libm, so the
// plant models of the simulator and of the emulated boards compute identical
// coefficients. The host design toolkit does general c2d; this covers the
// resonances and first-order lags the core's own plant presets need.
#pragma once

#include "piezoloop/biquad.hpp"
#include "piezoloop/det_math.hpp"
#include "piezoloop/status.hpp"

namespace piezoloop {

struct ContinuousSection {
    double b2 = 0.0, b1 = 0.0, b0 = 1.0;  // numerator, descending powers of s
    double a2 = 0.0, a1 = 0.0, a0 = 1.0;  // denominator, descending powers of s
};

constexpr Status tustin(const ContinuousSection& c, double rate_Hz, SosSection& out) {
    if (!is_finite(rate_Hz) || !(rate_Hz > 0.0)) return error("rate_Hz", "must be > 0");
    const double k = 2.0 * rate_Hz;
    if (c.a2 == 0.0 && c.b2 == 0.0) {
        // First order: map with (z - 1) and (z + 1) once, else a spurious
        // pole-zero pair would sit on the unit circle at z = -1.
        const double d0 = c.a1 * k + c.a0;
        if (!is_finite(d0) || d0 == 0.0) return error("a", "denominator vanishes at the Tustin map");
        out = SosSection{(c.b1 * k + c.b0) / d0, (-c.b1 * k + c.b0) / d0, 0.0, (-c.a1 * k + c.a0) / d0, 0.0};
        return ok_status();
    }
    const double k2 = k * k;
    // (z-1)^2 -> [1, -2, 1], (z-1)(z+1) -> [1, 0, -1], (z+1)^2 -> [1, 2, 1]
    const double n0 = c.b2 * k2 + c.b1 * k + c.b0;
    const double n1 = -2.0 * c.b2 * k2 + 2.0 * c.b0;
    const double n2 = c.b2 * k2 - c.b1 * k + c.b0;
    const double d0 = c.a2 * k2 + c.a1 * k + c.a0;
    const double d1 = -2.0 * c.a2 * k2 + 2.0 * c.a0;
    const double d2 = c.a2 * k2 - c.a1 * k + c.a0;
    if (!is_finite(d0) || d0 == 0.0) return error("a", "denominator vanishes at the Tustin map");
    out = SosSection{n0 / d0, n1 / d0, n2 / d0, d1 / d0, d2 / d0};
    return ok_status();
}

// Unit-DC-gain resonance w^2 / (s^2 + 2 zeta w s + w^2), w = 2 pi f.
constexpr ContinuousSection resonance(double f_Hz, double zeta) {
    const double w = 2.0 * 3.14159265358979323846 * f_Hz;
    return ContinuousSection{0.0, 0.0, w * w, 1.0, 2.0 * zeta * w, w * w};
}

// Unit-DC-gain first-order lag 1 / (s / w + 1), w = 2 pi f.
constexpr ContinuousSection first_order_lag(double f_Hz) {
    const double w = 2.0 * 3.14159265358979323846 * f_Hz;
    return ContinuousSection{0.0, 0.0, w, 0.0, 1.0, w};
}

}  // namespace piezoloop
