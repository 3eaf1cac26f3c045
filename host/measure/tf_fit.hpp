// A parametric model fitted to a measured frequency response:
// frequency-domain least squares with the Sanathanan–Koerner iteration
// (C. K. Sanathanan, J. Koerner, "Transfer function synthesis as a ratio of
// two complex polynomials", IEEE Trans. Automatic Control 8(1), 1963).
//
//   discrete:    G(z) = z^-K B(q) / A(q),  q = z^-1 = e^{-j w Ts},
//                B = b0 + b1 q + ... + bM q^M,  A = 1 + a1 q + ... + aN q^N
//   continuous:  G(s) = e^{-s K Ts} B(s) / A(s),  A monic of degree N, B of
//                degree M, in s / w_ref (w_ref: the highest measured angular
//                frequency) for conditioning; the delay is reported, not
//                part of the model.
//
// Iteration t minimises the linearised error
//     sum_i w_i |B(x_i) - G_i A(x_i)|^2 / |A_{t-1}(x_i)|^2
// (linear in the coefficients; A_0 = 1), whose fixed point weights the
// output error |G_i - B/A|^2 by w_i; w_i = 1 / var(G_i) when the measurement
// gives variances (lines without one get the median weight). Real and
// imaginary parts are stacked and solved by a column-pivoting QR with column
// scaling. Unstable poles (|z| > 1, Re s > 0) are reflected into the stable
// region (z -> 1 / conj z, s -> -conj s: |A| on the unit circle, or the
// imaginary axis, changes by a constant only, the phase by an all-pass), and
// B is then refitted with A fixed: the least-squares fit with those stable
// poles.
//
// Refused (std::invalid_argument, the reason named): more coefficients than
// measured lines, and a rank-deficient least-squares problem.
#pragma once

#include <complex>
#include <string>
#include <vector>

#include "lti/lti.hpp"

namespace piezoloop::measure {

struct TfFitOptions {
    int poles = 2;          // N
    int zeros = 1;          // M
    int delay_samples = 0;  // K
    bool continuous = false;
    double ts = 0.0;        // sample period of the measurement (s), > 0
    int max_iterations = 50;
    double tolerance = 1e-12;  // relative change of the coefficients that ends the iteration
};

struct DecadeError {
    double from_Hz = 0.0, to_Hz = 0.0;
    int lines = 0;
    double rms_rel = 0.0, max_rel = 0.0;  // |G_fit - G| / |G|
    double max_db = 0.0, max_deg = 0.0;
};

struct TfFit {
    design::Tf model;                  // discrete (ts > 0, delay included) or continuous (ts = 0, delay not)
    std::vector<design::cplx> poles;   // of the model (continuous: rad/s)
    int iterations = 0;
    int reflected = 0;                 // unstable poles reflected
    double delay_s = 0.0;              // continuous: the delay left out of the model
    std::vector<DecadeError> decades;
    double weighted_rms = 0.0;         // sqrt(mean w |G - B/A|^2): ~1 when the fit is within the noise
};

TfFit fit_tf(const std::vector<double>& f_Hz, const std::vector<design::cplx>& g, const std::vector<double>& var,
             const TfFitOptions& o);

// The fitted model's response at f_Hz (delay included).
std::vector<design::cplx> tf_fit_response(const TfFit& fit, const std::vector<double>& f_Hz);

}  // namespace piezoloop::measure
