// How much each axis's command moves the other axes, from a square n x n
// frequency response G (y_i <- u_j, mimo_frf_estimate.hpp): per line and per
// off-diagonal pair (i <- j)
//     c_ij(f) = |G_ij(f)| / |G_jj(f)|,  in dB: 20 log10 c_ij,
// the displacement of axis i per unit of axis j's own displacement when only
// u_j moves (-40 dB: 1 %). Summary per pair: the low-frequency coupling,
// 20 log10 of the mean of c_ij over the low-frequency lines (the lines at or
// below below_Hz; default the lowest 3), and the largest c_ij over all lines
// with its frequency.
#pragma once

#include <optional>
#include <vector>

#include <Eigen/Dense>

namespace piezoloop::measure {

struct CouplingPair {
    int output = 0, input = 0;          // i <- j, 0-based
    std::vector<double> coupling_db;    // per line
    double low_frequency_db = 0.0;      // over the low-frequency lines
    double max_db = 0.0, max_Hz = 0.0;  // the largest over all lines
};

struct Coupling {
    std::vector<int> low_lines;         // the lines (indices) the low-frequency figures average
    std::vector<CouplingPair> pairs;    // (0 <- 1), (0 <- 2), (1 <- 0), ... row by row
};

// The lines at or below below_Hz (default: the lowest 3, or all if fewer).
// Throws std::invalid_argument naming below_Hz when no line is at or below it.
std::vector<int> low_frequency_lines(const std::vector<double>& f_Hz, std::optional<double> below_Hz);

// Throws std::invalid_argument when G is not square, the sizes differ, or a
// diagonal element is 0 (the axis does not move at that line).
Coupling coupling(const std::vector<double>& f_Hz, const std::vector<Eigen::MatrixXcd>& G,
                  std::optional<double> below_Hz = std::nullopt);

}  // namespace piezoloop::measure
