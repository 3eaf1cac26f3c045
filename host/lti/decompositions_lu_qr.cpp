// The LU and QR decompositions of lti/decompositions.hpp, compiled once.
#include "lti/decompositions.hpp"

template class Eigen::PartialPivLU<Eigen::MatrixXd>;
template class Eigen::PartialPivLU<Eigen::MatrixXcd>;
template class Eigen::FullPivLU<Eigen::MatrixXd>;
template class Eigen::FullPivLU<Eigen::MatrixXcd>;
template class Eigen::HouseholderQR<Eigen::MatrixXd>;
template class Eigen::ColPivHouseholderQR<Eigen::MatrixXd>;
