// The filters every commercial piezo controller offers (docs/models.md, 'Biquad cascades'), as
// continuous Zpk from physical parameters, and discretised by Tustin
// pre-warped at the filter's own frequency (so the notch centre / corner /
// lead-lag centre lands exactly where asked, whatever the rate).
//
//  * Notch: (s^2 + 2 zz w0 s + w0^2) / (s^2 + 2 zp w0 s + w0^2), unity
//    gain far from w0. Depth d = zz / zp (|H(j w0)|, in dB < -3.01). Width:
//    the distance between the two -3 dB frequencies, which for this form
//    is exactly 2 w0 sqrt(zp^2 - 2 zz^2), so
//      zp = (width / (2 f0)) / sqrt(1 - 2 d^2),  zz = d zp.
//    (In the discrete filter the -3 dB points move slightly, by the Tustin
//    frequency warping away from f0.)
//  * Low-pass, second order: w0^2 / (s^2 + (w0 / Q) s + w0^2); zeta = 1/(2Q).
//  * Lead-lag, first order: gain (1 + s / wz) / (1 + s / wp), DC gain
//    `gain`; a lead for fz < fp (phase peak at sqrt(fz fp)), a lag for
//    fz > fp. Pre-warped at sqrt(fz fp).
//
// Invalid parameters throw std::invalid_argument naming the parameter and
// the allowed range ("frequency_hz: must be in (0, rate/2 = 50000)").
#pragma once

#include <numbers>

#include "lti/lti.hpp"

namespace piezoloop::design {

struct NotchSpec {
    double frequency_hz = 0.0;
    double depth_db = -40.0;  // < -3.01; -inf not allowed (use e.g. -200)
    double width_hz = 0.0;    // between the -3 dB points, > 0
};

struct LowpassSpec {
    double frequency_hz = 0.0;
    double q = 1.0 / std::numbers::sqrt2;  // > 0; set q or zeta (q = 1 / (2 zeta))
};

struct LeadLagSpec {
    double zero_hz = 0.0;
    double pole_hz = 0.0;
    double gain = 1.0;  // DC gain, finite and != 0
};

Zpk notch_continuous(const NotchSpec& s);
Zpk lowpass_continuous(const LowpassSpec& s);
Zpk leadlag_continuous(const LeadLagSpec& s);

// Discrete at rate_hz (Tustin pre-warped at the filter's frequency). The
// filter's frequencies must lie below Nyquist.
Zpk notch(const NotchSpec& s, double rate_hz);
Zpk lowpass(const LowpassSpec& s, double rate_hz);
Zpk leadlag(const LeadLagSpec& s, double rate_hz);

}  // namespace piezoloop::design
