// The exact sampled transfer matrix of a linear stage of one to three
// coupled axes (docs/models.md, 'Coupled axes'), in double:
//
//   G_ij(z) = S_i(z) (1 + e_i) [delta_ij + sum_{paths j -> i} C(z)] D_j(z) g_j A_j(z)
//
// from the command u_j (V) to reading_i / sensor gain (µm), at
// z = e^{j 2 pi f / rate}: A_j the amplifier (gain, Tustin lag), g_j the
// linear hysteresis gain (µm/V), D_j the dynamics and C the coupling paths in
// the sections the float stage runs (double coefficients, before their
// rounding to float), S_i the sensor's Tustin lag and e_i its gain error.
// The converters count as ideal and the clamps as open (small signals);
// noise, offset, mains pickup and drift are additive and not part of G.
// What the float stage computes, up to float rounding.
#pragma once

#include <complex>
#include <vector>

#include "sim/scenario.hpp"

namespace piezoloop::sim {

// G[i][j]: from input j to output i, n x n (n = 1 for a single-axis plant).
using TransferMatrix = std::vector<std::vector<std::complex<double>>>;

// Refuses (std::invalid_argument naming the field) a stage that is not
// linear: a hysteresis other than kind "none" ("plant.axes[0].hysteresis:
// ..."), or creep (updated every n samples: not time-invariant); and f_Hz
// outside [0, rate / 2].
TransferMatrix exact_transfer_matrix(const Scenario& s, double f_Hz);

}  // namespace piezoloop::sim
