// Welch's segment averaging (P. D. Welch, IEEE Trans. Audio Electroacoust.
// 15(2), 1967), the part the frequency response's H1 estimate and the
// console's power spectral density share: segments of n samples every
// `step` samples, each with its mean removed and a periodic Hann window
// applied, and the DFT of each.
#pragma once

#include <cmath>
#include <complex>
#include <cstddef>
#include <initializer_list>
#include <numbers>
#include <span>
#include <utility>
#include <vector>

#include <unsupported/Eigen/FFT>

namespace piezoloop::measure {

// The periodic Hann window of n samples (scipy.signal.get_window("hann", n)).
inline std::vector<double> hann_window(std::size_t n) {
    std::vector<double> w(n);
    for (std::size_t k = 0; k < n; ++k)
        w[k] = 0.5 - 0.5 * std::cos(2.0 * std::numbers::pi * static_cast<double>(k) / static_cast<double>(n));
    return w;
}

// For every whole segment of the signals (all as long as the first), calls
// use(spectra) with spectra[i] the n-point DFT of signal i's segment, mean
// removed and multiplied by `window` (n = window.size()). Returns the number
// of segments.
template <class Sample, class Use>
int for_each_welch_segment(std::initializer_list<std::span<const Sample>> signals, const std::vector<double>& window,
                           std::size_t step, Use use) {
    const std::size_t n = window.size();
    const std::size_t length = signals.begin()->size();
    Eigen::FFT<double> fft;
    std::vector<double> seg(n);
    std::vector<std::vector<std::complex<double>>> spectra(signals.size());
    int segments = 0;
    for (std::size_t start = 0; start + n <= length; start += step) {
        std::size_t i = 0;
        for (const std::span<const Sample> x : signals) {
            double mean = 0.0;
            for (std::size_t k = 0; k < n; ++k) mean += static_cast<double>(x[start + k]);
            mean /= static_cast<double>(n);
            for (std::size_t k = 0; k < n; ++k) seg[k] = (static_cast<double>(x[start + k]) - mean) * window[k];
            fft.fwd(spectra[i++], seg);
        }
        use(std::as_const(spectra));
        ++segments;
    }
    return segments;
}

}  // namespace piezoloop::measure
