// Orthogonal multisines for measuring the n x n frequency response of a stage
// with n coupled axes (n = 1..3), all inputs excited at once on every line
// (Pintelon & Schoukens, System Identification: A Frequency Domain Approach,
// 2nd ed., Wiley 2012, ch. 3, "orthogonal multisines" for MIMO systems).
//
// The lines are the single-axis multisine's (frf_plan.hpp, multisine_lines:
// N = floor(rate / from_Hz), bins k1..k2 of N in the band) with its
// Schroeder phases phi_j = -pi j (j + 1) / K, j = k - k1, K = k2 - k1 + 1
// (excitation.hpp). The measurement is n experiments (blocks); in block b
// input l carries, one period of N samples,
//     u_l,b[t] = bias_l + a sum_{k=k1..k2} cos(2 pi k t / N + phi_j + 2 pi b l / n),
// so at line k the n x n matrix of the inputs' spectra (rows: inputs,
// columns: blocks) is
//     U(k) = (a N / 2) e^{j phi_j} T,   T_lb = e^{j 2 pi b l / n},
// the DFT matrix, orthogonal: T^H T = n I, so U is as well conditioned as
// can be (condition 1). The line amplitude a is one for all inputs, blocks
// and lines: the largest |u - bias| over every input and block is exactly
// amplitude_V (a = amplitude_V / max over l, b, t of |sum cos(...)|).
// Each block runs D = transient_periods discarded periods, then P = periods
// measured ones: (D + P) N samples per input.
#pragma once

#include <cstdint>
#include <vector>

#include "measure/frf_estimate.hpp"

namespace piezoloop::measure {

struct MimoFrfRequest {
    int inputs = 2;              // n, 1..3
    double rate_Hz = 0.0;        // the loop rate
    double from_Hz = 0.0, to_Hz = 0.0;
    double amplitude_V = 0.0;    // the peak of u - bias over every input and block
    std::vector<double> bias_V;  // per input (empty: 0)
    int periods = 10;            // measured periods per block (P)
    int transient_periods = 1;   // discarded periods before them (D)
};

struct MimoFrfPlan {
    int inputs = 0;
    MultisineLayout layout;              // rate, N, k1..k2
    int periods = 0, transient_periods = 0;
    uint64_t block_samples = 0;          // (D + P) N, per input per block
    uint64_t measured_start = 0;         // D N: the first measured sample of a block
    double line_amplitude_V = 0.0;       // a: each line's cosine amplitude
    std::vector<double> bias_V;          // per input
    std::vector<double> frequency_Hz;    // k rate / N, k = k1..k2
    std::vector<double> schroeder_rad;   // phi_j per line
};

// Checks the request (each field's range; a block of at most
// kMaxRecordTicks samples, record_bound.hpp); throws std::invalid_argument
// naming the field and the allowed range.
MimoFrfPlan plan_mimo_frf(const MimoFrfRequest& r);

// One period (N samples) of input `input` in block `block`, bias included.
std::vector<double> mimo_period(const MimoFrfPlan& p, int block, int input);

// The whole block `block`: per input, (D + P) N samples (the period
// repeated), what the host feeds to the stage's n command channels at once.
std::vector<std::vector<double>> mimo_block(const MimoFrfPlan& p, int block);

}  // namespace piezoloop::measure
