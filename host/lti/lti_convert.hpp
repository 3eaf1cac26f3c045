// Conversions between the LTI forms of lti.hpp (Tf, Zpk, Ss) and series
// composition, accurate for the sources' 6th–9th order models whose
// polynomial coefficients span 1e0 … 1e23.
//
// How accuracy is kept:
//  * Roots come from the eigenvalues of a companion matrix of the polynomial
//    in a scaled variable t = s / alpha (alpha = geometric mean of the root
//    magnitudes, a power of two), balanced (Parlett–Reinsch), then polished
//    by guarded Newton steps. Complex roots come out as exact conjugates.
//  * Zpk -> Ss builds a cascade of real first- and second-order blocks, each
//    in a scaled form (poles s^2 + a1 s + w0^2 as [[-a1, -w0], [w0, 0]]),
//    with the gain spread evenly over the blocks: no polynomial of degree > 2
//    is ever multiplied out.
//  * Ss -> Zpk: poles are eig(A) of A balanced; zeros come from the system
//    balanced as a whole ([A B; C 0]): the infinite zeros are deflated one
//    by one with Householder rotations (SISO case of Emami-Naeini & Van
//    Dooren), then the finite ones are the generalised eigenvalues (QZ) of
//    the remaining Rosenbrock pencil [A B; C D] - s [I 0; 0 0]. The gain
//    is the first non-zero Markov parameter, collected along the deflation.
//    Accuracy is that of any method on unstructured A, B, C: absolute
//    errors ~ eps |A| times the roots' condition; Zpk -> Ss -> Zpk of the
//    sources' models holds to 1e-10 (poles) and 1e-8 (response).
//  * Any Ss loses the small values of a response that spans many decades
//    (y = C x + D u cancels); evaluate such models as Zpk.
//  * Only zpk2tf / ss2tf multiply polynomials out (that is what a Tf is);
//    use Zpk wherever possible.
//
// Implemented in lti_convert.cpp (Tf <-> Zpk, series), zpk2ss.cpp, ss2zpk.cpp
// (with balancing) and poly.cpp, sharing lti_convert_detail.hpp.
//
// All functions throw std::invalid_argument with a message naming what is
// wrong (e.g. "tf.den[0]: leading coefficient must be non-zero").
#pragma once

#include <vector>

#include "lti/lti.hpp"

namespace piezoloop::design {

// ---- polynomials (descending powers, real coefficients) -------------------

// Roots of p (p[0] != 0 after stripping leading zeros; a constant has none).
// Complex roots are returned as exact conjugate pairs (+imag first), real
// roots with imag exactly 0. Order: by increasing magnitude.
std::vector<cplx> poly_roots(const std::vector<double>& p);

// Monic real polynomial with the given roots (conjugate pairs required,
// matched to a relative 1e-9); multiplied as real quadratic factors.
std::vector<double> poly_from_roots(const std::vector<cplx>& roots);

// Product of two polynomials.
std::vector<double> poly_mul(const std::vector<double>& a, const std::vector<double>& b);

// Splits roots into real ones and one member (imag > 0) of each conjugate
// pair. Throws if a complex root has no conjugate partner (relative 1e-9).
// `what` names the field in the error message (e.g. "zpk.poles").
void split_conjugates(const std::vector<cplx>& roots, std::vector<double>& real,
                      std::vector<cplx>& upper, const char* what = "roots");

// Returns the roots with conjugate partners made exact, ordered by
// increasing magnitude, pairs as (+imag, -imag). Throws like split_conjugates.
std::vector<cplx> canonical_roots(const std::vector<cplx>& roots, const char* what = "roots");

// ---- conversions -----------------------------------------------------------

Zpk tf2zpk(const Tf& tf);
Tf zpk2tf(const Zpk& zpk);
// Requires a proper model (#zeros <= #poles).
Ss zpk2ss(const Zpk& zpk);
Ss tf2ss(const Tf& tf);  // = zpk2ss(tf2zpk(tf))
Zpk ss2zpk(const Ss& ss);
Tf ss2tf(const Ss& ss);  // = zpk2tf(ss2zpk(ss))

// Diagonal similarity by powers of two (exact) that balances the row and
// column norms of A (Parlett–Reinsch, as LAPACK's gebal without permutation);
// B and C are scaled alike so that the transfer function is unchanged.
Ss balance(const Ss& ss);
// The same for the whole system matrix [A B; C 0] (the input/output index
// not scaled), as MATLAB's ssbal: B and C end up of the size of the rows and
// columns of A they couple to.
Ss balance_system(const Ss& ss);

// ---- composition (same ts required; the first model's input goes first) ---

Zpk series(const std::vector<Zpk>& models);
Zpk series(const Zpk& first, const Zpk& second);
Tf series(const Tf& first, const Tf& second);
Ss series(const Ss& first, const Ss& second);

// Number of poles minus number of zeros.
int relative_degree(const Zpk& zpk);

}  // namespace piezoloop::design
