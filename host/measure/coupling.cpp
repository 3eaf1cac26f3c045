#include "measure/coupling.hpp"

#include <cmath>
#include <stdexcept>
#include <string>

#include "format/number.hpp"

namespace piezoloop::measure {

std::vector<int> low_frequency_lines(const std::vector<double>& f_Hz, std::optional<double> below_Hz) {
    std::vector<int> lines;
    if (f_Hz.empty()) throw std::invalid_argument("frequency_Hz: no lines");
    if (!below_Hz) {
        for (int j = 0; j < static_cast<int>(f_Hz.size()) && j < 3; ++j) lines.push_back(j);
        return lines;
    }
    if (!std::isfinite(*below_Hz) || !(*below_Hz > 0.0)) throw std::invalid_argument("below_Hz: must be > 0 Hz");
    for (int j = 0; j < static_cast<int>(f_Hz.size()); ++j)
        if (f_Hz[static_cast<std::size_t>(j)] <= *below_Hz) lines.push_back(j);
    if (lines.empty())
        throw std::invalid_argument("below_Hz: must be >= the lowest line, " + format::significant(f_Hz.front(), 10) +
                                    " Hz (got " + format::significant(*below_Hz, 10) + ")");
    return lines;
}

Coupling coupling(const std::vector<double>& f_Hz, const std::vector<Eigen::MatrixXcd>& G, std::optional<double> below_Hz) {
    if (G.size() != f_Hz.size() || G.empty())
        throw std::invalid_argument("response: must have one matrix per line (" + std::to_string(f_Hz.size()) + ")");
    const Eigen::Index n = G[0].rows();
    for (std::size_t k = 0; k < G.size(); ++k) {
        if (G[k].rows() != n || G[k].cols() != n)
            throw std::invalid_argument("response: coupling needs a square n x n response at every line");
        for (Eigen::Index j = 0; j < n; ++j)
            if (!(std::abs(G[k](j, j)) > 0.0))
                throw std::invalid_argument("response: G" + std::to_string(j + 1) + std::to_string(j + 1) + " is 0 at " +
                                            format::significant(f_Hz[k], 10) + " Hz: the axis does not move");
    }
    Coupling c;
    c.low_lines = low_frequency_lines(f_Hz, below_Hz);
    for (Eigen::Index i = 0; i < n; ++i)
        for (Eigen::Index j = 0; j < n; ++j) {
            if (i == j) continue;
            CouplingPair p;
            p.output = static_cast<int>(i);
            p.input = static_cast<int>(j);
            double mean = 0.0;
            for (std::size_t k = 0; k < G.size(); ++k) {
                const double ratio = std::abs(G[k](i, j)) / std::abs(G[k](j, j));
                p.coupling_db.push_back(20.0 * std::log10(ratio));
                if (k == 0 || p.coupling_db.back() > p.max_db) {
                    p.max_db = p.coupling_db.back();
                    p.max_Hz = f_Hz[k];
                }
            }
            for (const int k : c.low_lines)
                mean += std::abs(G[static_cast<std::size_t>(k)](i, j)) / std::abs(G[static_cast<std::size_t>(k)](j, j));
            p.low_frequency_db = 20.0 * std::log10(mean / static_cast<double>(c.low_lines.size()));
            c.pairs.push_back(std::move(p));
        }
    return c;
}

}  // namespace piezoloop::measure
