#include "measure/static_decoupling.hpp"

#include <cmath>
#include <limits>
#include <stdexcept>
#include <string>

#include "format/number.hpp"

namespace piezoloop::measure {

double condition_1(const Eigen::MatrixXd& a) {
    const Eigen::FullPivLU<Eigen::MatrixXd> lu(a);
    if (!lu.isInvertible()) return std::numeric_limits<double>::infinity();
    const Eigen::MatrixXd inv = lu.inverse();
    // The 1-norm: the largest column sum of magnitudes.
    return a.cwiseAbs().colwise().sum().maxCoeff() * inv.cwiseAbs().colwise().sum().maxCoeff();
}

StaticDecoupling decouple_static_gain(const Eigen::MatrixXd& g0, double max_condition) {
    const Eigen::Index n = g0.rows();
    if (n < 1 || g0.cols() != n || !g0.allFinite()) throw std::invalid_argument("G0: must be a finite square matrix");
    for (Eigen::Index j = 0; j < n; ++j)
        if (g0(j, j) == 0.0)
            throw std::invalid_argument("G0: its diagonal element " + std::to_string(j + 1) + std::to_string(j + 1) +
                                        " is 0: axis " + std::to_string(j + 1) + " has no static gain of its own");
    StaticDecoupling s;
    s.g0 = g0;
    s.condition_1 = condition_1(g0);
    if (!(s.condition_1 <= max_condition))
        throw std::invalid_argument("G0: ill-conditioned, 1-norm condition " + format::significant(s.condition_1) +
                                    " > " + format::significant(max_condition) +
                                    ": no static decoupling (it would amplify the measurement's error)");
    s.output_matrix = g0.fullPivLu().inverse() * g0.diagonal().asDiagonal();
    const Eigen::MatrixXd after = g0 * s.output_matrix;
    s.static_after_db = Eigen::MatrixXd::Constant(n, n, std::numeric_limits<double>::quiet_NaN());
    for (Eigen::Index i = 0; i < n; ++i)
        for (Eigen::Index j = 0; j < n; ++j)
            if (i != j) s.static_after_db(i, j) = 20.0 * std::log10(std::fabs(after(i, j)) / std::fabs(after(j, j)));
    return s;
}

StaticDecoupling static_decoupling(const std::vector<double>& f_Hz, const std::vector<Eigen::MatrixXcd>& G,
                                   std::optional<double> below_Hz, double max_condition) {
    // coupling() checks the sizes and the squareness first.
    const Coupling before = coupling(f_Hz, G, below_Hz);
    const Eigen::Index n = G[0].rows();
    Eigen::MatrixXcd mean = Eigen::MatrixXcd::Zero(n, n);
    for (const int k : before.low_lines) mean += G[static_cast<std::size_t>(k)];
    mean /= static_cast<double>(before.low_lines.size());
    StaticDecoupling s = decouple_static_gain(mean.real(), max_condition);
    s.low_lines = before.low_lines;
    std::vector<Eigen::MatrixXcd> gd;
    for (const Eigen::MatrixXcd& g : G) gd.push_back(g * s.output_matrix.cast<std::complex<double>>());
    s.after = coupling(f_Hz, gd, below_Hz);
    return s;
}

}  // namespace piezoloop::measure
