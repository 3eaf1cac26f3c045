#include "ui/psd.hpp"

#include <complex>
#include <stdexcept>
#include <string>

#include "measure/welch_segments.hpp"

namespace piezoloop::ui {

Psd welch_psd(std::span<const float> x, double rate_Hz, std::size_t segment) {
    if (!(rate_Hz > 0.0)) throw std::invalid_argument("psd: the rate must be positive");
    if (segment < 16 || segment > (std::size_t{1} << 20))
        throw std::invalid_argument("psd.segment: " + std::to_string(segment) + " is outside [16, 1048576] samples");
    if (x.size() < 16) throw std::invalid_argument("psd: " + std::to_string(x.size()) + " samples, at least 16 needed");
    const std::size_t n = std::min(segment, x.size());
    const std::size_t step = n - n / 2;
    const std::vector<double> window = measure::hann_window(n);
    double window_power = 0.0;
    for (const double w : window) window_power += w * w;
    const std::size_t bins = n / 2 + 1;
    Psd out;
    out.segment = n;
    out.density.assign(bins, 0.0);
    out.segments = static_cast<std::size_t>(measure::for_each_welch_segment<float>(
        {x}, window, step, [&](const auto& spectra) {
            for (std::size_t b = 0; b < bins; ++b) out.density[b] += std::norm(spectra[0][b]);
        }));
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
