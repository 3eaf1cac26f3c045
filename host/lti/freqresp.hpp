// Frequency response of the LTI forms of lti.hpp at s = jw (continuous) or
// z = e^{jw ts} (discrete), w in rad/s for both.
//
//  * Zpk is evaluated as the product of its factors, gain * prod(x - z_i) /
//    prod(x - p_i), interleaving zeros and poles so that the running product
//    stays in range: exact to a few ulps per factor, whatever the spread of
//    the coefficients.
//  * Tf by Horner in x for |x| <= 1 and in 1/x for |x| > 1 (no overflow, the
//    dominant terms are summed last). Accuracy is bounded by the Tf itself:
//    prefer Zpk for ill-conditioned models.
//  * Ss by solving (xI - A) v = B with a complex LU of the balanced system.
//  * Discrete models in freqresp(): z - r is formed as (e^{jwTs} - 1) +
//    (1 - r), with e^{jwTs} - 1 = -2 sin^2(wTs/2) + j sin(wTs), so poles
//    near z = 1 (|1 - p| ~ 3e-5 for K(s) at 100 kHz) and low frequencies
//    keep full relative accuracy (forming z first would cancel).
#pragma once

#include <vector>

#include "lti/lti.hpp"

namespace piezoloop::design {

// Value of the model at the complex point x (s or z).
cplx evaluate(const Zpk& zpk, cplx x);
cplx evaluate(const Tf& tf, cplx x);
cplx evaluate(const Ss& ss, cplx x);

// The point at which a model with sample period ts is evaluated for the
// angular frequency w (rad/s): jw if ts == 0, e^{jw ts} otherwise.
cplx frequency_point(double w_rad_s, double ts);

// e^{j theta} - 1 without cancellation: -2 sin^2(theta/2) + j sin(theta).
cplx expj_minus_one(double theta);

std::vector<cplx> freqresp(const Zpk& zpk, const std::vector<double>& w_rad_s);
std::vector<cplx> freqresp(const Tf& tf, const std::vector<double>& w_rad_s);
std::vector<cplx> freqresp(const Ss& ss, const std::vector<double>& w_rad_s);

// Gain at DC (s = 0 or z = 1); +-inf for a pole there, 0 for a zero.
double dc_gain(const Zpk& zpk);

// n points from lo to hi (both > 0, n >= 2) spaced evenly in log: like
// numpy.logspace(log10(lo), log10(hi), n) but taking the end values
// themselves. Endpoints are returned exactly.
std::vector<double> logspace(double lo, double hi, int n);

// Hz <-> rad/s for frequency grids.
std::vector<double> hz_to_rad_s(const std::vector<double>& f_hz);

double magnitude_db(cplx h);
double phase_deg(cplx h);

}  // namespace piezoloop::design
