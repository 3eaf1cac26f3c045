#include "measure/step_response.hpp"

#include <algorithm>
#include <cmath>
#include <limits>
#include <stdexcept>
#include <vector>

namespace piezoloop::measure {

StepFigures analyse_step(std::span<const double> y, double sample_period_s, std::size_t step_index,
                         const StepOptions& o) {
    if (!(sample_period_s > 0.0) || !std::isfinite(sample_period_s))
        throw std::invalid_argument("step response: the sample period must be > 0");
    if (step_index < 1 || step_index + 2 > y.size())
        throw std::invalid_argument("step response: needs a sample before the step and two after it");
    if (!(o.settle_band > 0.0 && o.settle_band < 1.0) || !(o.final_fraction > 0.0 && o.final_fraction <= 1.0))
        throw std::invalid_argument("step response: settle band and final fraction must be in (0, 1)");
    for (const double v : y)
        if (!std::isfinite(v)) throw std::invalid_argument("step response: the record has non-finite samples");
    const std::size_t n_post = y.size() - step_index;
    StepFigures f;
    double sum = 0.0;
    for (std::size_t k = 0; k < step_index; ++k) sum += y[k];
    f.initial = sum / static_cast<double>(step_index);
    const std::size_t n_tail = std::max<std::size_t>(1, static_cast<std::size_t>(o.final_fraction * n_post));
    sum = 0.0;
    for (std::size_t k = y.size() - n_tail; k < y.size(); ++k) sum += y[k];
    f.final_value = sum / static_cast<double>(n_tail);
    const double delta = f.final_value - f.initial;
    if (!(std::fabs(delta) > 0.0))
        throw NoStepResponse("step response: the reading did not move (its final value equals the initial one)");

    // Normalised response after the step: 0 -> 1 whatever the step's sign.
    std::vector<double> z(n_post);
    for (std::size_t i = 0; i < n_post; ++i) z[i] = (y[step_index + i] - f.initial) / delta;
    const double ts = sample_period_s;
    const auto peak = std::max_element(z.begin(), z.end());
    const std::size_t i_peak = static_cast<std::size_t>(peak - z.begin());
    f.peak = y[step_index + i_peak];
    f.peak_time_s = static_cast<double>(i_peak) * ts;
    f.overshoot_pct = std::max(0.0, (*peak - 1.0) * 100.0);

    // First time z reaches `level`, interpolated between the samples around
    // it (z starts near 0, below both levels).
    auto first_crossing = [&](double level) {
        for (std::size_t i = 0; i < n_post; ++i) {
            if (z[i] < level) continue;
            if (i == 0) return 0.0;
            return (static_cast<double>(i - 1) + (level - z[i - 1]) / (z[i] - z[i - 1])) * ts;
        }
        return std::numeric_limits<double>::quiet_NaN();
    };
    f.rise_time_s = first_crossing(0.9) - first_crossing(0.1);

    // The last sample outside the band; the response enters the band for good
    // between it and the next one, where z crosses the band's edge on its side.
    const double band = o.settle_band;
    std::size_t last_out = n_post;  // none
    for (std::size_t i = n_post; i-- > 0;) {
        if (std::fabs(z[i] - 1.0) > band) {
            last_out = i;
            break;
        }
    }
    if (last_out == n_post) {
        f.settling_time_s = 0.0;
        f.settled = true;
    } else if (last_out + 1 >= n_post) {
        f.settling_time_s = std::numeric_limits<double>::quiet_NaN();
        f.settled = false;
    } else {
        const double edge = z[last_out] > 1.0 ? 1.0 + band : 1.0 - band;
        const double frac = (edge - z[last_out]) / (z[last_out + 1] - z[last_out]);
        f.settling_time_s = (static_cast<double>(last_out) + frac) * ts;
        f.settled = true;
    }
    return f;
}

}  // namespace piezoloop::measure
