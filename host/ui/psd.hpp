// The scope's spectrum view: the power spectral density of a record by
// Welch's method (P. D. Welch, IEEE Trans. Audio Electroacoust. 15(2),
// 1967): segments of `segment` samples overlapping by half, each with its
// mean removed and a periodic Hann window, their periodograms averaged; one
// sided, in unit^2/Hz (the defaults of scipy.signal.welch, its reference in
// tests/golden/ui_welch.json).
#pragma once

#include <cstddef>
#include <span>
#include <vector>

namespace piezoloop::ui {

struct Psd {
    std::vector<double> frequency_Hz;  // 0 to rate / 2, rate / n apart
    std::vector<double> density;       // unit^2 / Hz
    std::size_t segment = 0;           // samples per segment (the record's length if shorter)
    std::size_t segments = 0;
};

// std::invalid_argument for fewer than 16 samples, a segment below 16 or
// above 2^20, or a rate that is not positive.
Psd welch_psd(std::span<const float> x, double rate_Hz, std::size_t segment);

}  // namespace piezoloop::ui
