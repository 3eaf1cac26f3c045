// Linear time-invariant SISO models on the host, in double precision:
// transfer function, zero-pole-gain, state space; continuous (ts == 0) or
// discrete (ts > 0, seconds). The design, analysis and identification tools
// of host/lti/, host/analysis/ and host/ident/ share these types.
//
// The sources publish 6th–9th order models whose polynomial coefficients
// span 1e0 … 1e23; multiplying such factors out loses precision, so the
// factored forms (Zpk, Series) are primary and conversions go through roots
// and eigenvalues (see conversions in lti_convert.hpp).
#pragma once

#include <complex>
#include <vector>

#include <Eigen/Dense>

#include "lti/decompositions.hpp"

namespace piezoloop::design {

using cplx = std::complex<double>;

// num and den in descending powers of s (or z), den[0] != 0.
struct Tf {
    std::vector<double> num;
    std::vector<double> den;
    double ts = 0.0;  // 0: continuous; > 0: discrete with this sample period (s)
};

// gain * prod(s - z_i) / prod(s - p_i). Complex roots appear in conjugate pairs.
struct Zpk {
    std::vector<cplx> zeros;
    std::vector<cplx> poles;
    double gain = 1.0;
    double ts = 0.0;
};

// x' = A x + B u, y = C x + D u (or x[k+1] = ..., for ts > 0).
struct Ss {
    Eigen::MatrixXd A;  // n x n
    Eigen::VectorXd B;  // n
    Eigen::RowVectorXd C;  // n
    double D = 0.0;
    double ts = 0.0;
};

inline bool is_discrete(double ts) { return ts > 0.0; }

}  // namespace piezoloop::design
