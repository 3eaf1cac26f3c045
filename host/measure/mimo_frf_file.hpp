// The file of an n x n (outputs x inputs) measured frequency response
// (mimo_frf_estimate.hpp), CSV, read by `analyze coupling`:
//
//   # piezoloop mimo-frf 1
//   # inputs=2 outputs=2 rate_Hz=10000 periods=10
//   f_Hz,G11_re,G11_im,G11_std,G12_re,G12_im,G12_std,G21_re,...,G22_std
//   10,<17 significant digits>,...
//
// Gij is output i <- input j (1-based), the pairs row by row; std is the
// element's standard deviation (|G| units, mimo_frf_estimate.hpp), `nan`
// when unknown (one period). One line per excited frequency, increasing,
// in (0, rate_Hz / 2]. The third line must name exactly the columns that
// inputs and outputs imply. Beside it a JSON summary (mimo_frf_summary).
#pragma once

#include <string>

#include <nlohmann/json.hpp>

#include "measure/mimo_frf_estimate.hpp"

namespace piezoloop::measure {

// The third line for a shape: f_Hz, then Gij_re, Gij_im, Gij_std.
std::string mimo_frf_columns(int inputs, int outputs);

// Throws std::runtime_error when the file cannot be written.
void write_mimo_frf(const std::string& path, const MimoFrfEstimate& e);

// Throws std::invalid_argument naming the file, the line and the field
// (header, inputs, outputs, rate_Hz, periods, a column, f_Hz, a value) that
// is missing or malformed. snr_db is recomputed; input_condition is empty.
MimoFrfEstimate load_mimo_frf_file(const std::string& path);

// The measurement in brief: shape, rate, periods, band, lines, per element
// the lowest and the median SNR (dB), the largest input condition.
nlohmann::json mimo_frf_summary(const MimoFrfEstimate& e);

// The summary as a JSON file (e.g. beside the CSV); throws
// std::runtime_error when it cannot be written.
void write_mimo_frf_summary(const std::string& path, const MimoFrfEstimate& e);

}  // namespace piezoloop::measure
