#include "analysis/analysis.hpp"

#include <cmath>
#include <numbers>
#include <stdexcept>

#include "lti/lti_convert.hpp"

namespace piezoloop::design {

FeedbackLoop feedback_loop(const Ss& plant, const Ss& controller) {
    const Ss& p = plant;
    const Ss& k = controller;
    if (p.ts != k.ts)
        throw std::invalid_argument("plant and controller must both be continuous or share the same ts");
    const auto nk = k.A.rows(), np = p.A.rows(), n = nk + np;
    if (k.B.size() != nk || k.C.size() != nk || p.B.size() != np || p.C.size() != np || k.A.cols() != nk ||
        p.A.cols() != np)
        throw std::invalid_argument("state-space dimensions disagree");
    const double delta = 1.0 + p.D * k.D;
    if (std::abs(delta) < 1e-12) throw std::invalid_argument("loop is ill-posed: 1 + D_plant D_controller = 0");

    // Series part L = P K with x = [xK; xP].
    Eigen::MatrixXd al = Eigen::MatrixXd::Zero(n, n);
    al.topLeftCorner(nk, nk) = k.A;
    al.bottomRightCorner(np, np) = p.A;
    al.bottomLeftCorner(np, nk) = p.B * k.C;
    Eigen::VectorXd bl(n);
    bl << k.B, p.B * k.D;
    Eigen::RowVectorXd cl(n);  // y = cl x + DP DK e + DP d
    cl << p.D * k.C, p.C;

    const Eigen::MatrixXd a = al - bl * cl / delta;
    Eigen::VectorXd bd = -bl * (p.D / delta);
    bd.tail(np) += p.B;
    Eigen::RowVectorXd cu = Eigen::RowVectorXd::Zero(n);
    cu.head(nk) = k.C;
    cu -= k.D * cl / delta;

    FeedbackLoop f;
    f.S = {a, bl / delta, -cl / delta, 1.0 / delta, p.ts};
    f.T = {a, bl / delta, cl / delta, p.D * k.D / delta, p.ts};
    f.KS = {a, bl / delta, cu, k.D / delta, p.ts};
    f.GS = {a, bd, cl / delta, p.D / delta, p.ts};
    return f;
}

std::vector<cplx> critical_points(const Zpk& plant, const Zpk& controller) {
    std::vector<cplx> c;
    for (const Zpk* m : {&plant, &controller}) {
        c.insert(c.end(), m->poles.begin(), m->poles.end());
        c.insert(c.end(), m->zeros.begin(), m->zeros.end());
    }
    return c;
}

LoopAnalysis analyze_loop(const Zpk& plant, const Zpk& controller, const LoopAnalysisOptions& options) {
    if (plant.ts != controller.ts)
        throw std::invalid_argument("plant and controller must both be continuous or share the same ts");
    const Ss p = zpk2ss(plant);
    const Ss k = zpk2ss(controller);
    const FeedbackLoop f = feedback_loop(p, k);
    LoopAnalysis r;
    r.ts = plant.ts;
    r.closed_loop_poles = ss_poles(f.S);
    r.stability_measure = stability_measure(f.S);
    r.stable = is_stable(f.S);
    r.hinf_S = hinf_norm(f.S, options.rel_tol);
    r.hinf_T = hinf_norm(f.T, options.rel_tol);
    r.hinf_KS = hinf_norm(f.KS, options.rel_tol);
    r.hinf_GS = hinf_norm(f.GS, options.rel_tol);

    std::vector<cplx> crit = critical_points(plant, controller);
    r.margins = loop_margins(series(k, p), crit);
    crit.insert(crit.end(), r.closed_loop_poles.begin(), r.closed_loop_poles.end());
    const double two_pi = 2.0 * std::numbers::pi;
    if (const auto bw = bandwidth_rad_s(f.T, crit)) r.bandwidth_Hz = *bw / two_pi;
    for (double f_Hz : options.phase_lag_at_Hz) {
        if (!(f_Hz > 0.0) || !std::isfinite(f_Hz)) throw std::invalid_argument("phase-lag frequency must be > 0");
        if (is_discrete(r.ts) && f_Hz > 0.5 / r.ts)
            throw std::invalid_argument("phase-lag frequency must not exceed the Nyquist frequency");
        const double w = two_pi * f_Hz;
        const cplx t = SsEvaluator(f.T).at_w(w);
        r.phase_lags.push_back({f_Hz, -unwrapped_phase_deg(f.T, crit, w), 20.0 * std::log10(std::abs(t))});
    }
    return r;
}

HinfResult weighted_hinf(const Zpk& weight, const Ss& closed_loop_map, double rel_tol) {
    if (weight.ts != closed_loop_map.ts)
        throw std::invalid_argument("weight and loop must both be continuous or share the same ts");
    return hinf_norm(series(closed_loop_map, zpk2ss(weight)), rel_tol);
}

}  // namespace piezoloop::design
