// The dense decompositions the host code runs on dynamic-size double and
// complex matrices, compiled once (decompositions_lu_qr.cpp,
// decompositions_svd.cpp, decompositions_eigen.cpp) instead of in every file
// that uses them. Each is thousands of lines of Eigen templates: without
// these declarations every translation unit instantiates and optimises its
// own copy (the SVD and QR were two thirds of the compile time of
// ident/rls.cpp). The instances are the code Eigen would otherwise generate
// inline; with -ffp-contract=off on x86-64 a call instead of inlining does
// not change a result bit.
//
// A member template (the eigensolvers' compute<InputType>) is declared for the
// input type the code passes most (a plain matrix); a call with another input type
// still instantiates its own copy, which is correct, only slower to compile.
//
// With PIEZOLOOP_DECOMPOSITIONS_INLINE defined, each file instantiates what it
// uses, as without this header: the fuzz builds (tests/fuzz) compile a few
// host files once with the sanitizers, where compiling every decomposition
// would cost more than it saves.
#pragma once

#include <Eigen/Dense>
#include <Eigen/Eigenvalues>

#ifndef PIEZOLOOP_DECOMPOSITIONS_INLINE
extern template class Eigen::PartialPivLU<Eigen::MatrixXd>;
extern template class Eigen::PartialPivLU<Eigen::MatrixXcd>;
extern template class Eigen::FullPivLU<Eigen::MatrixXd>;
extern template class Eigen::FullPivLU<Eigen::MatrixXcd>;
extern template class Eigen::HouseholderQR<Eigen::MatrixXd>;
extern template class Eigen::ColPivHouseholderQR<Eigen::MatrixXd>;

extern template class Eigen::JacobiSVD<Eigen::MatrixXd>;
extern template class Eigen::JacobiSVD<Eigen::MatrixXcd>;

extern template class Eigen::HessenbergDecomposition<Eigen::MatrixXd>;
extern template class Eigen::RealSchur<Eigen::MatrixXd>;
extern template class Eigen::EigenSolver<Eigen::MatrixXd>;
extern template Eigen::EigenSolver<Eigen::MatrixXd>& Eigen::EigenSolver<Eigen::MatrixXd>::compute<Eigen::MatrixXd>(
    const Eigen::EigenBase<Eigen::MatrixXd>&, bool);
extern template class Eigen::SelfAdjointEigenSolver<Eigen::MatrixXd>;
extern template Eigen::SelfAdjointEigenSolver<Eigen::MatrixXd>&
Eigen::SelfAdjointEigenSolver<Eigen::MatrixXd>::compute<Eigen::MatrixXd>(const Eigen::EigenBase<Eigen::MatrixXd>&, int);
extern template class Eigen::ComplexSchur<Eigen::MatrixXcd>;
extern template class Eigen::ComplexEigenSolver<Eigen::MatrixXcd>;
extern template Eigen::ComplexEigenSolver<Eigen::MatrixXcd>&
Eigen::ComplexEigenSolver<Eigen::MatrixXcd>::compute<Eigen::MatrixXcd>(const Eigen::EigenBase<Eigen::MatrixXcd>&, bool);
#endif
