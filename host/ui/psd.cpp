#include "ui/psd.hpp"

#include <cmath>
#include <complex>
#include <numbers>
#include <stdexcept>
#include <string>

#include <unsupported/Eigen/FFT>

namespace piezoloop::ui {

Psd welch_psd(std::span<const float> x, double rate_Hz, std::size_t segment) {
    if (!(rate_Hz > 0.0)) throw std::invalid_argument("psd: the rate must be positive");
    if (segment < 16 || segment > (std::size_t{1} << 20))
        throw std::invalid_argument("psd.segment: " + std::to_string(segment) + " is outside [16, 1048576] samples");
    if (x.size() < 16) throw std::invalid_argument("psd: " + std::to_string(x.size()) + " samples, at least 16 needed");
    const std::size_t n = std::min(segment, x.size());
    const std::size_t step = n - n / 2;
    std::vector<double> window(n);
    double window_power = 0.0;
    for (std::size_t k = 0; k < n; ++k) {
        window[k] = 0.5 - 0.5 * std::cos(2.0 * std::numbers::pi * static_cast<double>(k) / static_cast<double>(n));
        window_power += window[k] * window[k];
    }
    const std::size_t bins = n / 2 + 1;
    Psd out;
    out.segment = n;
    out.density.assign(bins, 0.0);
    Eigen::FFT<double> fft;
    std::vector<double> seg(n);
    std::vector<std::complex<double>> spectrum;
    for (std::size_t start = 0; start + n <= x.size(); start += step) {
        double mean = 0.0;
        for (std::size_t k = 0; k < n; ++k) mean += static_cast<double>(x[start + k]);
        mean /= static_cast<double>(n);
        for (std::size_t k = 0; k < n; ++k) seg[k] = (static_cast<double>(x[start + k]) - mean) * window[k];
        fft.fwd(spectrum, seg);
        for (std::size_t b = 0; b < bins; ++b) out.density[b] += std::norm(spectrum[b]);
        ++out.segments;
    }
    const double scale = 1.0 / (rate_Hz * window_power * static_cast<double>(out.segments));
    out.frequency_Hz.resize(bins);
    for (std::size_t b = 0; b < bins; ++b) {
        // One-sided: the negative frequencies' power folded onto the positive
        // ones, all but DC and (n even) the Nyquist bin, which have no twin.
        const bool single = b == 0 || (n % 2 == 0 && b == n / 2);
        out.density[b] *= scale * (single ? 1.0 : 2.0);
        out.frequency_Hz[b] = static_cast<double>(b) * rate_Hz / static_cast<double>(n);
    }
    return out;
}

}  // namespace piezoloop::ui
