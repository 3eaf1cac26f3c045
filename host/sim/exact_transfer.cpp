#include "sim/exact_transfer.hpp"

#include <cmath>
#include <stdexcept>
#include <string>

#include "piezoloop/plant.hpp"
#include "sim/coupled_stage_build.hpp"
#include "sim/design_bridge.hpp"

namespace piezoloop::sim {

namespace {

using cplx = std::complex<double>;

// FirstOrderLag's Tustin lag (stage_model.hpp), its coefficients in double:
// b (1 + z^-1) / (1 + a z^-1); 1 for a bandwidth of 0.
cplx tustin_lag(float bandwidth_Hz, float rate_Hz, cplx zinv) {
    if (bandwidth_Hz == 0.0f) return 1.0;
    const double w = 2.0 * 3.14159265358979323846 * bandwidth_Hz;
    const double k = 2.0 * static_cast<double>(rate_Hz);
    const double b = w / (k + w), a = (w - k) / (k + w);
    return b * (1.0 + zinv) / (1.0 + a * zinv);
}

cplx sections_response(const std::vector<SosSection>& sos, cplx zinv) {
    cplx h = 1.0;
    for (const SosSection& s : sos) h *= (s.b0 + zinv * (s.b1 + zinv * s.b2)) / (1.0 + zinv * (s.a1 + zinv * s.a2));
    return h;
}

struct LinearAxis {
    const PlantSpec* plant;
    std::string path;  // "plant" or "plant.axes[i]"
};

}  // namespace

TransferMatrix exact_transfer_matrix(const Scenario& s, double f_Hz) {
    if (!(f_Hz >= 0.0 && f_Hz <= 0.5 * s.rate_Hz))
        throw std::invalid_argument("f_Hz: must be in [0, rate / 2] (got " + std::to_string(f_Hz) + ")");
    std::vector<LinearAxis> axes;
    if (s.axes.empty()) axes.push_back({&s.plant, "plant"});
    for (const AxisSpec& a : s.axes) axes.push_back({&a.plant, a.path});
    for (const LinearAxis& a : axes) {
        if (a.plant->hysteresis.core != HysteresisKind::kNone)
            throw std::invalid_argument(a.path + ".hysteresis: the exact transfer matrix needs a linear stage: kind none (got " +
                                        a.plant->hysteresis.kind + ")");
        if (a.plant->creep.percent_per_decade > 0.0f)
            throw std::invalid_argument(a.path + ".creep: the exact transfer matrix needs a time-invariant stage: no creep "
                                        "(its lags are updated every n samples)");
    }
    const float rate = static_cast<float>(s.rate_Hz);  // as the float stage runs
    const cplx zinv = std::polar(1.0, -2.0 * M_PI * f_Hz / s.rate_Hz);
    const size_t n = axes.size();
    // x_j per volt of u_j, and each sensor's response per µm of position.
    std::vector<cplx> actuate(n), sense(n);
    for (size_t j = 0; j < n; ++j) {
        const PlantSpec& p = *axes[j].plant;
        cplx x = static_cast<double>(p.amplifier.gain) * tustin_lag(p.amplifier.bandwidth_Hz, rate, zinv) * p.hysteresis.gain_um_per_V;
        if (p.dynamics) {
            const std::string where = p.dynamics->path.empty() ? axes[j].path + ".dynamics" : p.dynamics->path;
            const bool advance = p.discretisation != "tustin";
            x *= sections_response(
                discretise_sos(p.dynamics->zpk, s.rate_Hz, p.discretisation, 0.0, advance, where, kMaxPlantSections), zinv);
        }
        actuate[j] = x;
        sense[j] = (1.0 + static_cast<double>(p.sensor.gain_error)) * tustin_lag(p.sensor.bandwidth_Hz, rate, zinv);
    }
    TransferMatrix g(n, std::vector<cplx>(n, 0.0));
    for (size_t i = 0; i < n; ++i) g[i][i] = 1.0;
    for (const CouplingSpec& c : s.coupling)
        g[static_cast<size_t>(c.to_axis)][static_cast<size_t>(c.from_axis)] += sections_response(coupling_sections(c, s.rate_Hz), zinv);
    for (size_t i = 0; i < n; ++i)
        for (size_t j = 0; j < n; ++j) g[i][j] = g[i][j] == 0.0 ? cplx(0.0) : sense[i] * g[i][j] * actuate[j];
    return g;
}

}  // namespace piezoloop::sim
