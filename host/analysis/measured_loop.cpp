#include "analysis/measured_loop.hpp"

#include <cmath>
#include <numbers>
#include <stdexcept>

#include "lti/freqresp.hpp"
#include "numeric_constants.hpp"

namespace piezoloop::design {

namespace {

constexpr double kDegPerRad = 180.0 / std::numbers::pi;

// Where, between lines a and b, the linear interpolation of v (on log f)
// reaches `level`; t in [0, 1] from a.
double crossing_t(double va, double vb, double level) { return (level - va) / (vb - va); }

double log_interp_f(double fa, double fb, double t) { return std::exp(std::log(fa) + t * (std::log(fb) - std::log(fa))); }

}  // namespace

MeasuredLoop measured_loop(const std::vector<double>& f_Hz, const std::vector<cplx>& plant, const Zpk& controller) {
    if (f_Hz.size() < 2) throw std::invalid_argument("frf: at least two lines are needed");
    if (plant.size() != f_Hz.size()) throw std::invalid_argument("frf: one response per line");
    for (std::size_t k = 0; k < f_Hz.size(); ++k) {
        if (!(f_Hz[k] > 0.0) || !std::isfinite(f_Hz[k]) || (k > 0 && !(f_Hz[k] > f_Hz[k - 1])))
            throw std::invalid_argument("frf: frequency_Hz[" + std::to_string(k) + "] must be positive and ascending");
        if (!std::isfinite(plant[k].real()) || !std::isfinite(plant[k].imag()) || plant[k] == 0.0)
            throw std::invalid_argument("frf: response[" + std::to_string(k) + "] must be finite and non-zero");
    }
    if (controller.ts > 0.0 && f_Hz.back() >= 0.5 / controller.ts)
        throw std::invalid_argument("controller: its Nyquist frequency (" + std::to_string(0.5 / controller.ts) +
                                    " Hz) must lie above the highest line");
    MeasuredLoop m;
    m.f_Hz = f_Hz;
    for (std::size_t k = 0; k < f_Hz.size(); ++k) {
        const cplx l = plant[k] * evaluate(controller, frequency_point(kTwoPi * f_Hz[k], controller.ts));
        if (!std::isfinite(l.real()) || !std::isfinite(l.imag()) || l == 0.0)
            throw std::invalid_argument("controller: its response at " + std::to_string(f_Hz[k]) +
                                        " Hz is zero or not finite");
        m.loop.push_back(l);
        double ph = std::arg(l) * kDegPerRad;
        if (k > 0) ph += 360.0 * std::round((m.phase_deg.back() - ph) / 360.0);  // the branch nearest the last line
        m.phase_deg.push_back(ph);
        const double s = 1.0 / std::abs(1.0 + l);
        if (s > m.max_sensitivity) m.max_sensitivity = s, m.max_sensitivity_Hz = f_Hz[k];
    }
    bool coarse = false;
    for (std::size_t k = 0; k + 1 < f_Hz.size(); ++k) {
        const double ga = 20.0 * std::log10(std::abs(m.loop[k])), gb = 20.0 * std::log10(std::abs(m.loop[k + 1]));
        const double pa = m.phase_deg[k], pb = m.phase_deg[k + 1];
        const bool step_coarse = std::abs(pb - pa) > 30.0 || std::abs(gb - ga) > 6.0;
        if ((ga >= 0.0) != (gb >= 0.0)) {
            const double t = crossing_t(ga, gb, 0.0);
            double pm = 180.0 + pa + t * (pb - pa);
            pm -= 360.0 * std::floor((pm + 180.0) / 360.0);  // (-180, 180]
            if (pm <= -180.0) pm += 360.0;
            m.gain_crossovers.push_back({log_interp_f(f_Hz[k], f_Hz[k + 1], t), pm});
            coarse = coarse || step_coarse;
        }
        // Odd multiples of 180° crossed between the lines.
        const double lo = std::min(pa, pb), hi = std::max(pa, pb);
        for (double c = 180.0 * (2.0 * std::ceil((lo - 180.0) / 360.0) + 1.0); c <= hi; c += 360.0) {
            if (c < lo || pa == pb) continue;
            const double t = crossing_t(pa, pb, c);
            const double g_db = ga + t * (gb - ga);
            m.phase_crossovers.push_back({log_interp_f(f_Hz[k], f_Hz[k + 1], t), -g_db});
            coarse = coarse || step_coarse;
        }
    }
    for (const MeasuredCrossing& c : m.gain_crossovers)
        if (!m.phase_margin || c.value < m.phase_margin->value) m.phase_margin = c;
    for (const MeasuredCrossing& c : m.phase_crossovers)
        if (!m.gain_margin || std::abs(c.value) < std::abs(m.gain_margin->value)) m.gain_margin = c;
    if (m.gain_crossovers.empty())
        m.warnings.push_back(std::string("no gain crossover inside the measured lines (|L| ") +
                             (std::abs(m.loop.front()) > 1.0 ? "> 1" : "< 1") +
                             " throughout): measure a wider band");
    if (coarse)
        m.warnings.push_back("a crossing lies between lines more than 30 deg or 6 dB apart: the margins there are "
                             "interpolated coarsely; measure with more lines around it");
    return m;
}

}  // namespace piezoloop::design
