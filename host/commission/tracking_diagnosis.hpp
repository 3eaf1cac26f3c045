// Why a tracking run on the stage went wrong, from its record (r, y, u per
// tick) over its last period (the one its figures are taken over): what a
// failed verification tells the user besides its figures.
//
//   limited    the command sat at a command limit (saturation, or the
//              limiter's clamp): the stage was asked for more than the span
//              gives at that speed;
//   rail       the sensor read the end of its range ten or more times: the
//              stage left what the sensor reads, the loop was blind there;
//   oscillation the error's part above 5x the triangle's frequency (e minus
//              its moving average over a fifth of the triangle's period),
//              when its RMS is above 0.5 % of the range: the loop rings or
//              is unstable; its frequency is the largest FFT bin of that
//              part, and it grows when its RMS over the record's second
//              half is more than 1.5x that over the first.
#pragma once

#include <string>
#include <vector>

namespace piezoloop::commission {

struct TrackingDiagnosis {
    double limited_fraction = 0.0;    // of the ticks, command within 1e-6 of the span of a limit
    double rail_fraction = 0.0;       // of the ticks, the reading at an end of the sensor's range
    double oscillation_rms_um = 0.0;  // RMS of the error's fast part
    double oscillation_Hz = 0.0;      // its largest frequency; 0 when below the threshold
    bool growing = false;
};

struct TrackingDiagnosisInputs {
    double rate_Hz = 0.0, triangle_Hz = 0.0, range_um = 0.0;
    double u_min_V = 0.0, u_max_V = 0.0;
    double sensor_min_um = 0.0, sensor_max_um = 0.0;
};

// r, y (µm) and u (V) of the same ticks, the last rate / triangle_Hz of
// them analysed (all when fewer). Throws std::invalid_argument when
// the lengths differ or the inputs are not finite and positive where needed.
TrackingDiagnosis diagnose_tracking(const std::vector<double>& r_um, const std::vector<double>& y_um,
                                    const std::vector<double>& u_V, const TrackingDiagnosisInputs& in);

// The reason in words, with what the user can do ("" when none of the
// causes shows: the run is then a model mismatch, said by the caller).
std::string describe(const TrackingDiagnosis& d, const TrackingDiagnosisInputs& in);

}  // namespace piezoloop::commission
