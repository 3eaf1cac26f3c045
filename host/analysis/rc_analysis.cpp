#include "analysis/rc_analysis.hpp"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <numbers>
#include <stdexcept>

#include <Eigen/Eigenvalues>

#include "analysis/analysis.hpp"
#include "lti/freqresp.hpp"
#include "analysis/hinf.hpp"
#include "lti/lti_convert.hpp"
#include "lti/text.hpp"
#include "analysis/margins.hpp"

namespace piezoloop::design {
namespace {

constexpr int kMaxHinfStates = 800;    // Hamiltonian for ||T_g0||

void validate(const RcConfig& rc, double ts) {
    if (!is_discrete(ts)) throw std::invalid_argument("rc: the loop must be discrete (ts > 0)");
    if (rc.q.ts != ts) throw std::invalid_argument("rc: q must be discrete with the loop's ts");
    if (rc.period_samples < 2) throw std::invalid_argument("rc: period_samples (N) must be >= 2");
    if (rc.m1 < 0) throw std::invalid_argument("rc: m1 must be >= 0");
    if (rc.m2 < 0) throw std::invalid_argument("rc: m2 must be >= 0");
    if (rc.period_samples - rc.m1 - rc.m2 < 1)
        throw std::invalid_argument("rc: N - m1 - m2 must be >= 1 so the lead stays causal");
    if (!(rc.k_rc > 0.0) || !std::isfinite(rc.k_rc)) throw std::invalid_argument("rc: k_rc must be > 0");
}

double hz(double w) { return w / (2.0 * std::numbers::pi); }

// Golden-section search for the extremum of f on [a, b] (sign = +1: max).
template <class F>
std::pair<double, double> golden(F f, double a, double b, double sign) {
    const double phi = (std::sqrt(5.0) - 1.0) / 2.0;
    double x1 = b - phi * (b - a), x2 = a + phi * (b - a);
    double f1 = sign * f(x1), f2 = sign * f(x2);
    for (int i = 0; i < 100 && (b - a) > 1e-14 * b; ++i) {
        if (f1 > f2) {
            b = x2; x2 = x1; f2 = f1; x1 = b - phi * (b - a); f1 = sign * f(x1);
        } else {
            a = x1; x1 = x2; f1 = f2; x2 = a + phi * (b - a); f2 = sign * f(x2);
        }
    }
    return f1 > f2 ? std::pair{x1, sign * f1} : std::pair{x2, sign * f2};
}

// Extremum of f over the grid, refined around the best few grid points.
template <class F>
std::pair<double, double> grid_extremum(F f, const std::vector<double>& w, double sign) {
    std::vector<double> v(w.size());
    for (std::size_t i = 0; i < w.size(); ++i) v[i] = sign * f(w[i]);
    std::vector<std::size_t> idx(w.size());
    for (std::size_t i = 0; i < idx.size(); ++i) idx[i] = i;
    const std::size_t top = std::min<std::size_t>(8, idx.size());
    std::partial_sort(idx.begin(), idx.begin() + static_cast<std::ptrdiff_t>(top), idx.end(),
                      [&](std::size_t a, std::size_t b) { return v[a] > v[b]; });
    double best_w = w[idx[0]], best = v[idx[0]];
    for (std::size_t k = 0; k < top; ++k) {
        const std::size_t i = idx[k];
        const double a = w[i == 0 ? 0 : i - 1], b = w[std::min(i + 1, w.size() - 1)];
        if (!(b > a)) continue;
        const auto [x, fx] = golden([&](double y) { return f(y); }, a, b, sign);
        if (sign * fx > best) {
            best = sign * fx;
            best_w = x;
        }
    }
    return {best_w, sign * best};
}

// Uniform grid (0, π/ts] with `count` points, plus a log grid below its
// first point: resolves the RC harmonics (spacing 2π/(N ts)).
std::vector<double> dense_grid(double ts, int count) {
    const double nyq = std::numbers::pi / ts;
    std::vector<double> w;
    const double first = nyq / count;
    for (int i = 0; i < 200; ++i) w.push_back(first * std::pow(1e-4, 1.0 - i / 200.0));
    for (int i = 1; i <= count; ++i) w.push_back(nyq * i / count);
    return w;
}

// L = T / (1 − T) (positive unity feedback around T).
Ss loop_from_closed(const Ss& t) {
    const double den = 1.0 - t.D;
    if (std::abs(den) < 1e-12) throw std::invalid_argument("rc: T(∞) = 1, the loop gain T/(1 − T) is improper");
    Ss l = t;
    l.A = t.A + t.B * t.C / den;
    l.B = t.B / den;
    l.C = t.C / den;
    l.D = t.D / den;
    return l;
}

RcAnalysis analyze(const Ss& t, const Ss& l, const RcConfig& rc, const std::optional<PiHysteresis>& pi) {
    const double ts = t.ts;
    validate(rc, ts);
    RcAnalysis r;
    r.ts = ts;
    r.period_samples = rc.period_samples;
    const double nyq = std::numbers::pi / ts;
    const int n_period = rc.period_samples;
    const Ss q = zpk2ss(rc.q);
    const SsEvaluator et(t), eq(q), el(l);
    r.loop_stable = is_stable(t);
    if (!r.loop_stable)
        r.failures.push_back(cat("the loop without RC is unstable (largest |z| = ", format::significant(stability_measure(t)),
                                 "): RC analysis presumes a stable T"));

    // Q's cutoff.
    std::vector<cplx> crit = ss_poles(t);
    crit.insert(crit.end(), rc.q.poles.begin(), rc.q.poles.end());
    crit.insert(crit.end(), rc.q.zeros.begin(), rc.q.zeros.end());
    const auto qbw = bandwidth_rad_s(q, crit);
    const double wc = qbw ? *qbw : nyq;
    r.q_cutoff_Hz = hz(wc);

    // θ = θT + m2 ω Ts, unwrapped along the analysis grid.
    const std::vector<double> grid = analysis_grid(crit, ts, {wc});
    const FrequencySamples st = sample_response(et, grid);
    if (st.w.empty()) throw std::invalid_argument("rc: T is zero on the whole frequency grid");
    auto theta_at = [&](std::size_t i) { return st.phase[i] + rc.m2 * st.w[i] * ts; };
    auto theta_near = [&](double w, double guess) { return phase_near(et, w, guess - rc.m2 * w * ts) + rc.m2 * w * ts; };

    // (3) and the frequency where |θ| reaches 90°.
    r.max_phase_deg = 0.0;
    double max_w = st.w.front();
    for (std::size_t i = 0; i < st.w.size(); ++i) {
        const double th = std::abs(theta_at(i));
        if (st.w[i] <= wc * (1.0 + 1e-12) && th * 180.0 / std::numbers::pi > r.max_phase_deg) {
            r.max_phase_deg = th * 180.0 / std::numbers::pi;
            max_w = st.w[i];
        }
        if (!r.phase_90_at_Hz && th >= std::numbers::pi / 2.0) {
            double a = i == 0 ? 0.0 : st.w[i - 1], b = st.w[i];
            const double ga = i == 0 ? 0.0 : theta_at(i - 1), gb = theta_at(i);
            for (int k = 0; k < 200 && b - a > 1e-13 * b; ++k) {
                const double m = 0.5 * (a + b);
                const double g = theta_near(m, ga + (gb - ga) * (m - a) / std::max(b - a, 1e-300));
                (std::abs(g) >= std::numbers::pi / 2.0 ? b : a) = m;
            }
            r.phase_90_at_Hz = hz(0.5 * (a + b));
        }
    }
    r.max_phase_at_Hz = hz(max_w);
    r.phase_ok = r.max_phase_deg < 90.0;
    if (!r.phase_ok)
        r.failures.push_back(cat("(3) |thetaT + theta2| reaches ", format::significant(r.max_phase_deg, 4), " deg at ",
                                 format::significant(r.max_phase_at_Hz), " Hz, below Q's cutoff ", format::significant(r.q_cutoff_Hz),
                                 " Hz (limit 90 deg): the Q cutoff must stay below ",
                                 format::significant(r.phase_90_at_Hz ? *r.phase_90_at_Hz : 0.0), " Hz"));

    // (2): k_rc_max = min over (0, ωc] of 2 cos θ / A.
    {
        std::vector<double> wg;
        for (double w : st.w)
            if (w <= wc * (1.0 + 1e-12)) wg.push_back(w);
        auto bound = [&](double w) {
            // θ on the branch of the nearest sample.
            const auto it = std::lower_bound(st.w.begin(), st.w.end(), w);
            const std::size_t i = std::min<std::size_t>(static_cast<std::size_t>(it - st.w.begin()), st.w.size() - 1);
            const double th = theta_near(w, theta_at(i));
            return 2.0 * std::cos(th) / std::abs(et.at_w(w));
        };
        if (wg.empty()) wg.push_back(st.w.front());
        const auto [w, v] = grid_extremum(bound, wg, -1.0);
        r.k_rc_max = v;
        r.k_rc_max_at_Hz = hz(w);
        r.gain_ok = rc.k_rc < r.k_rc_max;
        if (!r.gain_ok)
            r.failures.push_back(cat("(2) k_rc = ", format::significant(rc.k_rc), " is not below 2 cos(theta)/A = ", format::significant(r.k_rc_max),
                                     " (at ", format::significant(r.k_rc_max_at_Hz), " Hz): exceeds it by ",
                                     format::significant(rc.k_rc - r.k_rc_max)));
    }

    // (1): sup |Q| |1 − k_rc e^{jθ2} T| up to Nyquist.
    {
        auto f = [&](double w) {
            return std::abs(eq.at_w(w)) * std::abs(1.0 - rc.k_rc * std::polar(1.0, rc.m2 * w * ts) * et.at_w(w));
        };
        const auto [w, v] = grid_extremum(f, grid, 1.0);
        r.small_gain_peak = v;
        r.small_gain_at_Hz = hz(w);
        r.small_gain_ok = v < 1.0;
        if (!r.small_gain_ok)
            r.failures.push_back(cat("(1) sup |Q| |1 - k_rc z^m2 T| = ", format::significant(v), " >= 1 (at ", format::significant(r.small_gain_at_Hz),
                                     " Hz): the sufficient condition behind (2)-(3) fails"));
    }

    // Exact: roots of 1 − M.
    if (n_period - rc.m1 <= rc.max_exact_delay_states) {
        const Ss m = rc_characteristic(t, rc);
        const Eigen::MatrixXd a = m.A + m.B * m.C / (1.0 - m.D);
        Eigen::EigenSolver<Eigen::MatrixXd> es(a, false);
        if (es.info() == Eigen::Success) {
            double mx = 0.0;
            for (Eigen::Index i = 0; i < es.eigenvalues().size(); ++i) mx = std::max(mx, std::abs(es.eigenvalues()[i]));
            r.rc_max_abs_root = mx;
            r.rc_stable = mx < 1.0 && r.loop_stable;
            if (mx >= 1.0)
                r.failures.push_back(cat("exact: the RC loop is unstable, a root of 1 - M lies at |z| = ", format::significant(mx, 8)));
        }
    }

    // Hysteresis: (15) and (21).
    if (pi) {
        if (!std::isfinite(pi->g0) || pi->g0 == 0.0) throw std::invalid_argument("rc: pi g0 must be finite and non-zero");
        if (!(pi->spacing >= 0.0) || !std::isfinite(pi->spacing))
            throw std::invalid_argument("rc: pi spacing must be finite and >= 0");
        for (double d : pi->density)
            if (!std::isfinite(d)) throw std::invalid_argument("rc: pi density values must be finite");
        r.has_hysteresis = true;
        r.g0 = pi->g0;
        const int count = std::max(20000, 64 * n_period);
        const std::vector<double> dg = dense_grid(ts, count);
        auto lrc = [&](double w) { return el.at_w(w) * (1.0 + rc_response(rc, w, ts)); };
        // (15) M_GL: smallest critical gain k > 1 at a crossing of the
        // negative real axis.
        std::vector<cplx> h(dg.size());
        for (std::size_t i = 0; i < dg.size(); ++i) h[i] = lrc(dg[i]);
        for (std::size_t i = 0; i + 1 < dg.size(); ++i) {
            if (!(h[i].real() < 0.0 && h[i + 1].real() < 0.0)) continue;
            if ((h[i].imag() < 0.0) == (h[i + 1].imag() < 0.0)) continue;
            double a = dg[i], b = dg[i + 1];
            const bool neg_a = h[i].imag() < 0.0;
            for (int k = 0; k < 200 && b - a > 1e-14 * b; ++k) {
                const double m = 0.5 * (a + b);
                ((lrc(m).imag() < 0.0) == neg_a ? a : b) = m;
            }
            const double wx = 0.5 * (a + b);
            const cplx hx = lrc(wx);
            if (!(hx.real() < 0.0)) continue;
            const double k = 1.0 / std::abs(hx);
            if (k > 1.0 && (!r.gain_margin_rc || k < *r.gain_margin_rc)) {
                r.gain_margin_rc = k;
                r.gain_margin_rc_at_Hz = hz(wx);
            }
        }
        r.g0_ok = !r.gain_margin_rc || std::abs(pi->g0) <= *r.gain_margin_rc;
        // Loop with the hysteresis gain: plant g0 L, controller 1 + RC.
        Ss gl = l;
        gl.C *= pi->g0;
        gl.D *= pi->g0;
        const FeedbackLoop f = feedback_loop(gl, rc_plus_one(rc, ts));
        r.g0_loop_stable = f.T.A.rows() <= rc.max_exact_delay_states + 64 ? is_stable(f.T) : r.g0_ok;
        if (!r.g0_ok)
            r.failures.push_back(cat("(15) g0 = ", format::significant(pi->g0), " exceeds the RC loop's gain margin M_GL = ",
                                     format::significant(*r.gain_margin_rc), " (at ", format::significant(*r.gain_margin_rc_at_Hz), " Hz)"));
        if (!r.g0_loop_stable)
            r.failures.push_back(cat("(15) the RC loop with the hysteresis gain g0 = ", format::significant(pi->g0),
                                     " is unstable (eigenvalues)"));
        // (21): ||G2||∞ = ||T_g0||∞ / |g0|.
        auto tg0 = [&](double w) {
            const cplx x = pi->g0 * lrc(w);
            return std::abs(x / (1.0 + x));
        };
        const auto [wg, vg] = grid_extremum(tg0, dg, 1.0);
        double peak = vg, peak_w = wg;
        r.hinf_G2_method = "grid";
        if (f.T.A.rows() <= kMaxHinfStates && r.g0_loop_stable) {
            const HinfResult hr = hinf_norm(f.T, 1e-6);
            peak = hr.norm;
            peak_w = hr.peak_w_rad_s;
            r.hinf_G2_method = "hamiltonian";
        }
        r.hinf_G2 = peak / std::abs(pi->g0);
        r.hinf_G2_at_Hz = hz(peak_w);
        for (double d : pi->density) r.density_l1 += std::abs(d);
        if (pi->spacing > 0.0) r.density_integral = pi->spacing * r.density_l1;
        r.density_bound = 1.0 / (std::abs(pi->g0) * r.hinf_G2);
        r.density_ok = r.g0_loop_stable && r.density_l1 < r.density_bound;
        if (!r.g0_loop_stable)
            r.failures.push_back("(21) cannot hold: the linear RC loop with the hysteresis gain is unstable, so G2 "
                                 "is unbounded; inverse-PI feedforward alone will not make it stable");
        else if (!r.density_ok)
            r.failures.push_back(cat("(21) ||d||_1 = ", format::significant(r.density_l1), " is not below 1/(|g0| ||G2||inf) = ",
                                     format::significant(r.density_bound), " (||G2||inf = ", format::significant(r.hinf_G2), " at ",
                                     format::significant(r.hinf_G2_at_Hz), " Hz): inverse-PI feedforward is required"));
    }
    return r;
}

}  // namespace

cplx rc_response(const RcConfig& rc, double w, double ts) {
    const cplx z = std::polar(1.0, w * ts);
    const cplx h = evaluate(rc.q, z) * std::polar(1.0, (rc.m1 - rc.period_samples) * w * ts);
    return rc.k_rc * std::polar(1.0, rc.m2 * w * ts) * h / (1.0 - h);
}

Ss rc_plus_one(const RcConfig& rc, double ts) {
    validate(rc, ts);
    const Ss q = zpk2ss(rc.q);
    const int d1 = rc.period_samples - rc.m1, d2 = d1 - rc.m2;
    const auto nq = q.A.rows();
    const auto n = d1 + 2 * nq;
    // States: delay line x_i = s[k − i] (i = 1..d1), Q copy a (generator, fed
    // by s[k − d1]), Q copy b (output, fed by s[k − d2]);
    // s = e + X, X = Qa{s[k − d1]}, output e + k_rc Qb{s[k − d2]}.
    Ss o;
    o.ts = ts;
    o.A = Eigen::MatrixXd::Zero(n, n);
    o.B = Eigen::VectorXd::Zero(n);
    o.C = Eigen::RowVectorXd::Zero(n);
    const Eigen::Index ia = d1, ib = d1 + nq, x1 = 0, xd1 = d1 - 1, xd2 = d2 - 1;
    // s[k] = e + Ca xa + Da x_d1 -> x_1[k+1]
    o.A.block(x1, ia, 1, nq) = q.C;
    o.A(x1, xd1) += q.D;
    o.B(x1) = 1.0;
    for (Eigen::Index i = 1; i < d1; ++i) o.A(i, i - 1) = 1.0;
    o.A.block(ia, ia, nq, nq) = q.A;
    o.A.block(ia, xd1, nq, 1) += q.B;
    o.A.block(ib, ib, nq, nq) = q.A;
    o.A.block(ib, xd2, nq, 1) += q.B;
    o.C.segment(ib, nq) = rc.k_rc * q.C;
    o.C(xd2) += rc.k_rc * q.D;
    o.D = 1.0;
    return o;
}

Ss rc_characteristic(const Ss& t, const RcConfig& rc) {
    validate(rc, t.ts);
    const Ss q = zpk2ss(rc.q);
    const int d1 = rc.period_samples - rc.m1, d2 = d1 - rc.m2;
    const auto nq = q.A.rows(), nt = t.A.rows();
    const auto n = d1 + nt + nq;
    // States: delay line of the input w (x_i = w[k − i]), T fed by w[k − d2],
    // Q fed by v = w[k − d1] − k_rc (Ct xt + Dt w[k − d2]); output Q's.
    Ss o;
    o.ts = t.ts;
    o.A = Eigen::MatrixXd::Zero(n, n);
    o.B = Eigen::VectorXd::Zero(n);
    o.C = Eigen::RowVectorXd::Zero(n);
    const Eigen::Index it = d1, iq = d1 + nt, xd1 = d1 - 1, xd2 = d2 - 1;
    o.B(0) = 1.0;
    for (Eigen::Index i = 1; i < d1; ++i) o.A(i, i - 1) = 1.0;
    o.A.block(it, it, nt, nt) = t.A;
    o.A.block(it, xd2, nt, 1) += t.B;
    // v as a row over the states.
    Eigen::RowVectorXd v = Eigen::RowVectorXd::Zero(n);
    v(xd1) += 1.0;
    v.segment(it, nt) -= rc.k_rc * t.C;
    v(xd2) -= rc.k_rc * t.D;
    o.A.block(iq, iq, nq, nq) = q.A;
    o.A.block(iq, 0, nq, n) += q.B * v;
    o.C = q.D * v;
    o.C.segment(iq, nq) += q.C;
    o.D = 0.0;
    return o;
}

RcAnalysis analyze_rc_closed_loop(const Ss& t, const RcConfig& rc, const std::optional<PiHysteresis>& pi) {
    return analyze(t, loop_from_closed(t), rc, pi);
}

RcAnalysis analyze_rc_loop_gain(const Ss& l, const RcConfig& rc, const std::optional<PiHysteresis>& pi) {
    Ss one;
    one.A = Eigen::MatrixXd::Zero(0, 0);
    one.B = Eigen::VectorXd::Zero(0);
    one.C = Eigen::RowVectorXd::Zero(0);
    one.D = 1.0;
    one.ts = l.ts;
    return analyze(feedback_loop(l, one).T, l, rc, pi);
}

}  // namespace piezoloop::design
