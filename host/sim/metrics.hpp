// Tracking and hysteresis metrics as the sources define them (docs/models.md, 'Metrics'),
// computed on one steady-state period of logged signals.
#pragma once

#include <span>

namespace piezoloop::sim {

struct TrackingMetrics {
    double range_um = 0.0;   // reference range r_max - r_min over the period
    double e_max_um = 0.0;   // max |e|
    double e_pp_um = 0.0;    // peak-to-peak error
    double e_rms_um = 0.0;   // RMS error
    double e_max_pct = 0.0;  // e_max / range * 100
    double e_rms_pct = 0.0;  // e_rms / range * 100
};

// r and y over the same samples (one steady-state period).
TrackingMetrics tracking_metrics(std::span<const double> r, std::span<const double> y);

// Hysteresis % (Ahmad2020 eq. 25–26, Janaideh2016 §V-B): at the input
// midpoint V_M the rising and falling branches give X_up and X_lo, found by
// linear interpolation between samples; result |X_up - X_lo| / (X_max - X_min)
// * 100. `input` and `output` cover one steady-state cycle. Returns a negative
// value if the input does not cross its midpoint both ways.
double hysteresis_pct(std::span<const double> input, std::span<const double> output);

}  // namespace piezoloop::sim
