// The n x n (n_out x n) frequency response from the recorded blocks of an
// orthogonal-multisine measurement (mimo_frf_plan.hpp; Pintelon & Schoukens
// 2012, ch. 3). Nothing here knows where the records came from.
//
// Per block b and measured period p, the DFT at each excited bin k of every
// input and output (scaled to peak units, 2 X / N) gives the columns
//     U_p(k)[:, b],  Y_p(k)[:, b];
// their means over the P periods Ubar (n x n: inputs x blocks) and Ybar
// (n_out x n) give
//     G(k) = Ybar(k) Ubar(k)^{-1}.
// The *recorded* u is used, not the planned one, so a quantised or limited
// command does not bias G. The uncertainty per element comes from the
// period-to-period spread: G_p = Y_p U_p^{-1} per period, and
//     std G_ij = sqrt( sum_p |G_p,ij - mean_p G_p,ij|^2 / (P (P - 1)) ),
// the sample standard deviation of one period's estimate divided by sqrt(P)
// (the standard deviation of a mean of P periods; complex: sqrt E|e|^2).
// With noise on y only, G_p is linear in Y_p and mean_p G_p = G exactly; with
// noise on u as well the two agree to first order. P = 1: std is NaN.
// SNR per element: 20 log10(|G_ij| / std G_ij) dB.
#pragma once

#include <vector>

#include <Eigen/Dense>

#include "measure/mimo_frf_plan.hpp"

namespace piezoloop::measure {

struct MimoFrfEstimate {
    int inputs = 0, outputs = 0, periods = 0;
    double rate_Hz = 0.0;
    std::vector<double> frequency_Hz;
    std::vector<Eigen::MatrixXcd> response;  // per line, outputs x inputs: y_i <- u_j
    std::vector<Eigen::MatrixXd> std_dev;    // per line, per element, |G| units (NaN for P = 1)
    std::vector<Eigen::MatrixXd> snr_db;     // per line, per element
    std::vector<double> input_condition;     // per line: 2-norm condition of the measured Ubar
};

// u[b][l]: input l of block b, y[b][i]: output i of block b, each the whole
// block as planned ((D + P) N samples: the first D periods are skipped).
// Throws std::invalid_argument naming what does not fit the plan (block
// count, channel count, length) or a singular measured input matrix.
MimoFrfEstimate estimate_mimo_frf(const MimoFrfPlan& plan, const std::vector<std::vector<std::vector<double>>>& u,
                                  const std::vector<std::vector<std::vector<double>>>& y);

}  // namespace piezoloop::measure
