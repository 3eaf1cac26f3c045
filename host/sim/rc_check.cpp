#include "sim/rc_check.hpp"

#include <cmath>

#include "lti/lti_convert.hpp"
#include "piezoloop/pi_generalized.hpp"
#include "sim/design_bridge.hpp"

namespace piezoloop::sim {

namespace {

design::RcConfig rc_config(const Scenario& s, const CaseSpec& c, double f_ref_Hz, int max_exact_delay_states) {
    const double ts = 1.0 / s.rate_Hz;
    design::RcConfig rc;
    rc.max_exact_delay_states = max_exact_delay_states;
    rc.period_samples = c.rc.period_samples != 0 ? c.rc.period_samples
                                                 : static_cast<int>(std::llround(s.rate_Hz / f_ref_Hz));
    rc.m1 = c.rc.rc.m1;
    rc.m2 = c.rc.rc.m2;
    rc.k_rc = c.rc.rc.k_rc;
    const SosSection& q = c.rc.rc.q;
    // Q as one section b0 + b1 z^-1 + b2 z^-2 over 1 + a1 z^-1 + a2 z^-2.
    design::Tf qt{{q.b0, q.b1, q.b2}, {1.0, q.a1, q.a2}, ts};
    while (qt.num.size() > 1 && qt.num.front() == 0.0) qt.num.erase(qt.num.begin());
    rc.q = design::tf2zpk(qt);
    rc.q.ts = ts;
    return rc;
}

// A first-order lag of unit DC gain at f_Hz (none when 0).
void add_lag(design::Zpk& g, double f_Hz) {
    if (!(f_Hz > 0.0)) return;
    const double w = 2.0 * M_PI * f_Hz;
    g.poles.push_back({-w, 0.0});
    g.gain *= w;
}

// LTI feedback with the PI inverse in series: the linear loop of the header.
design::RcAnalysis lti_series_conditions(const Scenario& s, const CaseSpec& c, double f_ref_Hz, int max_exact) {
    design::Zpk g = s.plant.dynamics->zpk;
    add_lag(g, s.plant.amplifier.bandwidth_Hz);
    add_lag(g, s.plant.sensor.bandwidth_Hz);
    g = discretise(g, s.rate_Hz, "zoh", 0.0, false, "plant.dynamics.model");
    g.gain *= c.feedback.error_per_um;
    const design::Zpk k = discretise(c.feedback.model->zpk, s.rate_Hz, c.feedback.method, c.feedback.prewarp_Hz, false,
                                     c.feedback.path + ".model");
    return design::analyze_rc_loop_gain(design::zpk2ss(design::series(k, g)), rc_config(s, c, f_ref_Hz, max_exact));
}

}  // namespace

std::optional<design::RcAnalysis> rc_conditions(const Scenario& s, const CaseSpec& c, double f_ref_Hz,
                                                int max_exact_delay_states) {
    const HysteresisSpec& h = c.plant_hysteresis ? *c.plant_hysteresis : s.plant.hysteresis;
    if (c.rc.enabled && c.feedback.kind == "lti" && c.feedback.model && c.feedforward.kind == "pi_inverse" &&
        c.feedforward.placement == "series" && s.plant.dynamics)
        return lti_series_conditions(s, c, f_ref_Hz, max_exact_delay_states);
    if (!c.rc.enabled || c.feedback.kind != "pid" || h.kind != "shan_pi" || !s.plant.dynamics) return std::nullopt;
    const double ts = 1.0 / s.rate_Hz;
    // Shan2012's v = f + sum_j d_j F[f], f = g0 u_m + g1, on the model input
    // u_m = input_per_V * amplifier gain * u. With the command as the model's
    // input (Shan2012's setting) the hysteresis seen from u is v = g0' u + eta,
    // g0' = in_gain * amplifier gain (= the published g0); the plain model
    // holds p0 = 1 and the density as its weights.
    design::PiHysteresis pi;
    pi.g0 = h.in_gain * s.plant.amplifier.gain;
    for (int j = 0; j < h.plain.count; ++j) pi.density.push_back(h.plain.weights[static_cast<size_t>(j)]);

    const PidConfig& p = c.feedback.pid;
    design::Zpk gc;  // Kp + Ki Ts z/(z - 1) = ((Kp + Ki Ts) z - Kp)/(z - 1)
    gc.ts = ts;
    const double kp = p.kp, kits = static_cast<double>(p.ki_per_s) * ts;
    gc.poles = {{1.0, 0.0}};
    if (kp != 0.0) gc.zeros = {{kp / (kp + kits), 0.0}};
    gc.gain = kp + kits;
    design::Zpk g = discretise(s.plant.dynamics->zpk, s.rate_Hz, "zoh", 0.0, false, "plant.dynamics.model");
    // With the hysteresis replaced by v = u: model output -> µm -> the
    // controller's error unit; g0' and the density enter through (15), (21).
    g.gain *= h.out_gain * c.feedback.error_per_um;
    const design::Ss l = design::zpk2ss(design::series(gc, g));
    return design::analyze_rc_loop_gain(l, rc_config(s, c, f_ref_Hz, max_exact_delay_states), pi);
}

}  // namespace piezoloop::sim
