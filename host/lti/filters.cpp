#include "lti/filters.hpp"
#include "lti/text.hpp"

#include <cmath>
#include <cstdio>
#include <numbers>
#include <stdexcept>
#include <string>

#include "lti/c2d.hpp"
#include "numeric_constants.hpp"

namespace piezoloop::design {
namespace {

void require(bool ok, const char* field, const std::string& range) {
    if (!ok) throw std::invalid_argument(cat(field, ": ", range));
}

void check_rate(double rate_hz) {
    require(std::isfinite(rate_hz) && rate_hz > 0.0, "rate_hz", "must be finite and > 0");
}

void check_below_nyquist(double f, double rate_hz, const char* field) {
    require(std::isfinite(f) && f > 0.0 && f < 0.5 * rate_hz, field,
            cat("must be in (0, rate/2 = ", format::significant(0.5 * rate_hz), ") Hz"));
}

// Roots of s^2 + 2 zeta w0 s + w0^2 (complex pair for zeta < 1, else two
// real roots, the product form kept accurate).
void quadratic_roots(double zeta, double w0, std::vector<cplx>& out) {
    if (zeta < 1.0) {
        const cplx r(-zeta * w0, w0 * std::sqrt((1.0 - zeta) * (1.0 + zeta)));
        out.push_back(r);
        out.push_back(std::conj(r));
    } else {
        const double big = -w0 * (zeta + std::sqrt((zeta - 1.0) * (zeta + 1.0)));
        out.emplace_back(big, 0.0);
        out.emplace_back(w0 * w0 / big, 0.0);
    }
}

}  // namespace

Zpk notch_continuous(const NotchSpec& s) {
    require(std::isfinite(s.frequency_hz) && s.frequency_hz > 0.0, "frequency_hz", "must be finite and > 0");
    require(std::isfinite(s.width_hz) && s.width_hz > 0.0, "width_hz", "must be finite and > 0");
    // -3.0103 dB = 1/sqrt(2): the -3 dB points exist only for a deeper notch.
    require(std::isfinite(s.depth_db) && s.depth_db < -3.0103 && s.depth_db >= -300.0, "depth_db",
            "must be in [-300, -3.0103) dB (a -3 dB width needs a notch deeper than -3 dB)");
    const double d = std::pow(10.0, s.depth_db / 20.0);
    const double q = s.width_hz / (2.0 * s.frequency_hz);
    const double zp = q / std::sqrt(1.0 - 2.0 * d * d);
    const double zz = d * zp;
    const double w0 = kTwoPi * s.frequency_hz;
    Zpk z;
    quadratic_roots(zz, w0, z.zeros);
    quadratic_roots(zp, w0, z.poles);
    z.gain = 1.0;
    return z;
}

Zpk lowpass_continuous(const LowpassSpec& s) {
    require(std::isfinite(s.frequency_hz) && s.frequency_hz > 0.0, "frequency_hz", "must be finite and > 0");
    require(std::isfinite(s.q) && s.q > 0.0, "q", "must be finite and > 0 (zeta = 1 / (2 q))");
    const double w0 = kTwoPi * s.frequency_hz;
    Zpk z;
    quadratic_roots(0.5 / s.q, w0, z.poles);
    z.gain = w0 * w0;
    return z;
}

Zpk leadlag_continuous(const LeadLagSpec& s) {
    require(std::isfinite(s.zero_hz) && s.zero_hz > 0.0, "zero_hz", "must be finite and > 0");
    require(std::isfinite(s.pole_hz) && s.pole_hz > 0.0, "pole_hz", "must be finite and > 0");
    require(std::isfinite(s.gain) && s.gain != 0.0, "gain", "must be finite and non-zero");
    const double wz = kTwoPi * s.zero_hz, wp = kTwoPi * s.pole_hz;
    // gain (1 + s/wz) / (1 + s/wp) = gain (wp / wz) (s + wz) / (s + wp)
    Zpk z;
    z.zeros = {cplx(-wz, 0.0)};
    z.poles = {cplx(-wp, 0.0)};
    z.gain = s.gain * wp / wz;
    return z;
}

Zpk notch(const NotchSpec& s, double rate_hz) {
    check_rate(rate_hz);
    check_below_nyquist(s.frequency_hz, rate_hz, "frequency_hz");
    return tustin(notch_continuous(s), 1.0 / rate_hz, kTwoPi * s.frequency_hz);
}

Zpk lowpass(const LowpassSpec& s, double rate_hz) {
    check_rate(rate_hz);
    check_below_nyquist(s.frequency_hz, rate_hz, "frequency_hz");
    return tustin(lowpass_continuous(s), 1.0 / rate_hz, kTwoPi * s.frequency_hz);
}

Zpk leadlag(const LeadLagSpec& s, double rate_hz) {
    check_rate(rate_hz);
    check_below_nyquist(s.zero_hz, rate_hz, "zero_hz");
    check_below_nyquist(s.pole_hz, rate_hz, "pole_hz");
    const Zpk c = leadlag_continuous(s);
    return tustin(c, 1.0 / rate_hz, kTwoPi * std::sqrt(s.zero_hz * s.pole_hz));
}

}  // namespace piezoloop::design
