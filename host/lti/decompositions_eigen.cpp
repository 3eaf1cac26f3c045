// The Schur forms and eigensolvers of lti/decompositions.hpp, compiled once.
#include "lti/decompositions.hpp"

template class Eigen::HessenbergDecomposition<Eigen::MatrixXd>;
template class Eigen::RealSchur<Eigen::MatrixXd>;
template class Eigen::EigenSolver<Eigen::MatrixXd>;
template Eigen::EigenSolver<Eigen::MatrixXd>& Eigen::EigenSolver<Eigen::MatrixXd>::compute<Eigen::MatrixXd>(
    const Eigen::EigenBase<Eigen::MatrixXd>&, bool);
template class Eigen::SelfAdjointEigenSolver<Eigen::MatrixXd>;
template Eigen::SelfAdjointEigenSolver<Eigen::MatrixXd>&
Eigen::SelfAdjointEigenSolver<Eigen::MatrixXd>::compute<Eigen::MatrixXd>(const Eigen::EigenBase<Eigen::MatrixXd>&, int);
template class Eigen::ComplexSchur<Eigen::MatrixXcd>;
template class Eigen::ComplexEigenSolver<Eigen::MatrixXcd>;
template Eigen::ComplexEigenSolver<Eigen::MatrixXcd>&
Eigen::ComplexEigenSolver<Eigen::MatrixXcd>::compute<Eigen::MatrixXcd>(const Eigen::EigenBase<Eigen::MatrixXcd>&, bool);
