#include "synth/pi_notch.hpp"

#include <cmath>
#include <limits>
#include <numbers>
#include <stdexcept>

#include "analysis/analysis.hpp"
#include "lti/freqresp.hpp"
#include "numeric_constants.hpp"

namespace piezoloop::design {

namespace {

struct PiNotchCandidate {
    Zpk controller;
    double kp = 0.0;
    std::vector<Notch> notches;
};

// The controller for crossover w_c (rad/s), kp not yet scaled (kp = 1).
PiNotchCandidate shape(const Zpk& plant, double w_c, const PiNotchOptions& o) {
    PiNotchCandidate c;
    c.controller.ts = 0.0;
    c.controller.gain = 1.0;
    c.controller.zeros.push_back(-w_c / o.integral_ratio);
    c.controller.poles.push_back(-o.leak * w_c);
    for (const cplx p : plant.poles) {
        if (!(p.imag() > 0.0)) continue;  // one of each pair
        const double wn = std::abs(p), zeta = -p.real() / wn;
        if (zeta >= o.resonance_damping_max || wn <= 1.5 * w_c || zeta <= 0.0) continue;
        c.controller.zeros.push_back(p);
        c.controller.zeros.push_back(std::conj(p));
        const cplx q(-o.notch_damping * wn, wn * std::sqrt(1.0 - o.notch_damping * o.notch_damping));
        c.controller.poles.push_back(q);
        c.controller.poles.push_back(std::conj(q));
        c.notches.push_back({wn / kTwoPi, zeta, o.notch_damping});
    }
    return c;
}

// The sign of the plant's low-frequency gain (so that kp closes a negative
// feedback loop): from the DC gain, or just above DC for an integrator.
double plant_sign(const Zpk& plant, double w_c) {
    const double g0 = dc_gain(plant);
    if (std::isfinite(g0) && g0 != 0.0) return g0 > 0.0 ? 1.0 : -1.0;
    const cplx g = evaluate(plant, cplx(0.0, 1e-3 * w_c));
    return std::real(g * cplx(0.0, 1e-3 * w_c)) >= 0.0 ? 1.0 : -1.0;  // s G(s) at s -> 0 for an integrator
}

}  // namespace

PiNotchDesign design_pi_notch(const Zpk& plant, double crossover_Hz, const PiNotchOptions& o) {
    if (plant.ts != 0.0) throw std::invalid_argument("plant: must be continuous (s in rad/s)");
    if (plant.poles.empty()) throw std::invalid_argument("plant: needs at least one pole");
    for (const cplx p : plant.poles)
        if (p.real() > 0.0 || (p.real() == 0.0 && p != 0.0))
            throw std::invalid_argument("plant: poles must be stable or at the origin");
    if (!(crossover_Hz > 0.0) || !std::isfinite(crossover_Hz))
        throw std::invalid_argument("crossover_hz: must be finite and > 0");
    if (!(o.pm_min_deg >= 0.0 && o.pm_min_deg < 180.0)) throw std::invalid_argument("pm_min_deg: must be in [0, 180)");
    if (!(o.gm_min_db >= 0.0) || !std::isfinite(o.gm_min_db)) throw std::invalid_argument("gm_min_db: must be finite and >= 0");
    PiNotchDesign d;
    d.target_Hz = crossover_Hz;
    for (double f = crossover_Hz; f >= o.min_fraction * crossover_Hz; f *= o.step) {
        const double w_c = kTwoPi * f;
        PiNotchCandidate c = shape(plant, w_c, o);
        const double mag = std::abs(evaluate(plant, cplx(0.0, w_c)) * evaluate(c.controller, cplx(0.0, w_c)));
        if (!(mag > 0.0) || !std::isfinite(mag)) continue;
        c.kp = plant_sign(plant, w_c) / mag;
        c.controller.gain = c.kp;
        const LoopAnalysis a = analyze_loop(plant, c.controller);
        if (!a.stable || !a.margins.phase_margin) continue;
        const double pm = a.margins.phase_margin->phase_margin_deg;
        const double gm = a.margins.gain_margin ? a.margins.gain_margin->gain_margin_db
                                                : std::numeric_limits<double>::infinity();
        if (pm < o.pm_min_deg || gm < o.gm_min_db) continue;
        d.controller = c.controller;
        d.kp = c.kp;
        d.integral_Hz = f / o.integral_ratio;
        d.crossover_Hz = f;
        d.notches = c.notches;
        d.phase_margin_deg = pm;
        d.gain_margin_db = gm;
        d.hinf_S = a.hinf_S.norm;
        if (f < crossover_Hz)
            d.warnings.push_back("crossover lowered from " + std::to_string(crossover_Hz) + " Hz to " +
                                 std::to_string(f) + " Hz to meet PM >= " + std::to_string(o.pm_min_deg) +
                                 " deg and GM >= " + std::to_string(o.gm_min_db) + " dB");
        for (const cplx p : plant.poles) {
            const double wn = std::abs(p);
            if (p.imag() > 0.0 && -p.real() / wn < o.resonance_damping_max && wn <= 1.5 * w_c)
                d.warnings.push_back("resonance at " + std::to_string(wn / kTwoPi) +
                                     " Hz is at or below 1.5 x the crossover: not notched");
        }
        return d;
    }
    throw std::invalid_argument("crossover_hz: no crossover between " + std::to_string(o.min_fraction * crossover_Hz) +
                                " and " + std::to_string(crossover_Hz) + " Hz gives a stable loop with PM >= " +
                                std::to_string(o.pm_min_deg) + " deg and GM >= " + std::to_string(o.gm_min_db) + " dB");
}

}  // namespace piezoloop::design
