// The singular value decompositions of lti/decompositions.hpp, compiled once.
#include "lti/decompositions.hpp"

template class Eigen::JacobiSVD<Eigen::MatrixXd>;
template class Eigen::JacobiSVD<Eigen::MatrixXcd>;
