// The singular value decomposition of lti/decompositions.hpp, compiled once.
#include "lti/decompositions.hpp"

template class Eigen::JacobiSVD<Eigen::MatrixXd>;
