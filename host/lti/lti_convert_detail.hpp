// Shared internals of the LTI conversions (lti_convert.hpp), used by
// lti_convert.cpp, poly.cpp, zpk2ss.cpp and ss2zpk.cpp only: error reporting,
// balancing, eigenvalues, root ordering, argument checks and the
// state-space block cascade.
#pragma once

#include <string>
#include <vector>

#include <Eigen/Dense>

#include "lti/lti.hpp"

namespace piezoloop::design::convert_detail {

[[noreturn]] void fail(const std::string& what);

bool all_finite(const std::vector<double>& v);

// Parlett–Reinsch balancing of a square matrix by powers of two; returns
// the diagonal d with A <- D^-1 A D.
// If `fixed_last`, the last row/column takes part in the norms but is never
// scaled itself (used for [A B; C 0], whose last index is the input/output).
Eigen::VectorXd balance_in_place(Eigen::MatrixXd& a, bool fixed_last = false);

std::vector<cplx> eigenvalues(const Eigen::MatrixXd& m);

// Order of roots: by magnitude, then real part, then |imag|.
bool root_less(cplx a, cplx b);

// Real roots and the +imag members of conjugate pairs, sorted by root_less,
// each pair written as (+imag, -imag).
std::vector<cplx> assemble(std::vector<double> real, std::vector<cplx> upper);

std::vector<double> strip_leading_zeros(const std::vector<double>& p);

void check_ss(const Ss& ss);
void check_ts(double a, double b, const char* what);

// A SISO state-space block; cascade(first, second) feeds first's output
// into second's input.
struct Block {
    Eigen::MatrixXd A;
    Eigen::VectorXd B;
    Eigen::RowVectorXd C;
    double D = 0.0;
};

Block cascade(const Block& first, const Block& second);

}  // namespace piezoloop::design::convert_detail
