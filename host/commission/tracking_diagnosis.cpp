#include "commission/tracking_diagnosis.hpp"

#include <algorithm>
#include <cmath>
#include <complex>
#include <stdexcept>

#include <unsupported/Eigen/FFT>

#include "format/number.hpp"

namespace piezoloop::commission {

namespace {


double rms(const std::vector<double>& x, std::size_t from, std::size_t to) {
    double s = 0.0;
    for (std::size_t i = from; i < to; ++i) s += x[i] * x[i];
    return to > from ? std::sqrt(s / static_cast<double>(to - from)) : 0.0;
}

}  // namespace

TrackingDiagnosis diagnose_tracking(const std::vector<double>& r_um, const std::vector<double>& y_um,
                                    const std::vector<double>& u_V, const TrackingDiagnosisInputs& in) {
    const std::size_t n = r_um.size();
    if (y_um.size() != n || u_V.size() != n) throw std::invalid_argument("tracking record: r, y and u differ in length");
    if (!(in.rate_Hz > 0.0) || !(in.triangle_Hz > 0.0) || !(in.range_um > 0.0) || !(in.u_max_V > in.u_min_V))
        throw std::invalid_argument("tracking diagnosis: rate, triangle frequency, range and command span must be > 0");
    TrackingDiagnosis d;
    // The last period only: the one the run's figures are taken over (the
    // approach and the first period take the start).
    const auto period = static_cast<std::size_t>(std::llround(in.rate_Hz / in.triangle_Hz));
    const std::size_t from = period >= 2 && period < n ? n - period : 0, m = n - from;
    if (m == 0) return d;

    const double u_tol = 1e-6 * (in.u_max_V - in.u_min_V);
    const double y_tol = 1e-6 * std::max(1.0, in.sensor_max_um - in.sensor_min_um);
    std::size_t limited = 0, rail = 0;
    for (std::size_t i = from; i < n; ++i) {
        if (u_V[i] <= in.u_min_V + u_tol || u_V[i] >= in.u_max_V - u_tol) ++limited;
        if (y_um[i] <= in.sensor_min_um + y_tol || y_um[i] >= in.sensor_max_um - y_tol) ++rail;
    }
    d.limited_fraction = static_cast<double>(limited) / static_cast<double>(m);
    d.rail_fraction = rail >= 10 ? static_cast<double>(rail) / static_cast<double>(m) : 0.0;

    // The error's fast part: e minus its centred moving average over a fifth
    // of the triangle's period (a running sum: O(m)).
    std::vector<double> e(m), fast(m);
    for (std::size_t i = 0; i < m; ++i) e[i] = r_um[from + i] - y_um[from + i];
    const std::size_t half = std::max<std::size_t>(1, static_cast<std::size_t>(0.1 * in.rate_Hz / in.triangle_Hz));
    std::vector<double> sum(m + 1, 0.0);
    for (std::size_t i = 0; i < m; ++i) sum[i + 1] = sum[i] + e[i];
    for (std::size_t i = 0; i < m; ++i) {
        const std::size_t a = i >= half ? i - half : 0, b = std::min(m, i + half + 1);
        fast[i] = e[i] - (sum[b] - sum[a]) / static_cast<double>(b - a);
    }
    d.oscillation_rms_um = rms(fast, 0, m);
    if (d.oscillation_rms_um > 0.005 * in.range_um) {
        d.growing = rms(fast, m / 2, m) > 1.5 * rms(fast, 0, m / 2);
        Eigen::FFT<double> fft;
        std::vector<std::complex<double>> spec;
        fft.fwd(spec, fast);
        std::size_t best = 1;
        for (std::size_t k = 1; k <= m / 2; ++k)
            if (std::abs(spec[k]) > std::abs(spec[best])) best = k;
        d.oscillation_Hz = static_cast<double>(best) * in.rate_Hz / static_cast<double>(m);
    }
    return d;
}

std::string describe(const TrackingDiagnosis& d, const TrackingDiagnosisInputs& in) {
    std::vector<std::string> why;
    if (d.oscillation_Hz > 0.0)
        why.push_back(std::string(d.growing ? "instability: a growing oscillation" : "the loop rings") + " at " +
                      format::significant(d.oscillation_Hz, 3) + " Hz (" + format::significant(d.oscillation_rms_um, 3) +
                      " um RMS): the loop is less stable on the stage than on the identified model; "
                      "a lower --target-bandwidth-hz (half the achieved bandwidth) gives it more margin");
    if (d.rail_fraction > 0.0)
        why.push_back("sensor rail: the reading sat at an end of the sensor's range (" + format::significant(in.sensor_min_um, 3) + " .. " +
                      format::significant(in.sensor_max_um, 3) + " um) for " + format::significant(100.0 * d.rail_fraction, 3) +
                      " % of the run: the stage left what the sensor reads; a smaller --range-um keeps it inside");
    if (d.limited_fraction > 0.01)
        why.push_back("saturation: the command sat at its limit (" + format::significant(in.u_min_V, 3) + " or " + format::significant(in.u_max_V, 3) +
                      " V) for " + format::significant(100.0 * d.limited_fraction, 3) +
                      " % of the run: the triangle asks for more than the command span gives there; a smaller "
                      "--range-um, or a slower triangle");
    std::string out;
    for (const std::string& w : why) out += (out.empty() ? "" : "; ") + w;
    return out;
}

}  // namespace piezoloop::commission
