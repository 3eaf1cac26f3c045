#include "synth/mimo_hinf.hpp"

#include <algorithm>
#include <cmath>
#include <limits>
#include <vector>

#include <Eigen/Eigenvalues>

#include "numeric_constants.hpp"

namespace piezoloop::design {
namespace {

double sigma_max(const StateSpace& g, double w) {
    const Eigen::MatrixXcd m = evaluate(g, {0.0, w});
    return Eigen::JacobiSVD<Eigen::MatrixXcd>(m).singularValues()(0);
}

// Frequencies (>= 0) of the near-imaginary eigenvalues of H(γ). Generous
// tolerance (1e-3 |λ|): a false detection costs one extra evaluation, a
// missed one would stop the iteration early (the argument of hinf.hpp).
std::vector<double> crossings(const StateSpace& g, double gamma) {
    const Eigen::Index n = g.states(), m = g.inputs(), p = g.outputs();
    const Eigen::MatrixXd R = g.D.transpose() * g.D - gamma * gamma * Eigen::MatrixXd::Identity(m, m);
    const Eigen::MatrixXd S = g.D * g.D.transpose() - gamma * gamma * Eigen::MatrixXd::Identity(p, p);
    const Eigen::MatrixXd Ri = R.inverse(), Si = S.inverse();
    Eigen::MatrixXd h(2 * n, 2 * n);
    const Eigen::MatrixXd a = g.A - g.B * Ri * g.D.transpose() * g.C;
    h << a, -gamma * g.B * Ri * g.B.transpose(), gamma * g.C.transpose() * Si * g.C, -a.transpose();
    const Eigen::VectorXcd ev = Eigen::EigenSolver<Eigen::MatrixXd>(h, false).eigenvalues();
    const double scale = h.cwiseAbs().rowwise().sum().maxCoeff();
    std::vector<double> w;
    for (Eigen::Index i = 0; i < ev.size(); ++i)
        if (std::fabs(ev[i].real()) <= 1e-3 * std::abs(ev[i]) + 1e-12 * scale && ev[i].imag() >= 0.0)
            w.push_back(ev[i].imag());
    std::sort(w.begin(), w.end());
    return w;
}

}  // namespace

MimoHinf hinf_norm_mimo(const StateSpace& g0, double rel_tol) {
    check_state_space(g0, "hinf_norm_mimo");
    MimoHinf r;
    const double dnorm = g0.D.size() ? Eigen::JacobiSVD<Eigen::MatrixXd>(g0.D).singularValues()(0) : 0.0;
    if (g0.states() == 0 || g0.inputs() == 0 || g0.outputs() == 0) {
        r.norm = r.upper = dnorm;
        r.peak_w_rad_s = kInf;
        return r;
    }
    StateSpace g = balance_states(g0);
    const Eigen::VectorXcd poles = g.A.eigenvalues();
    double wmin = kInf, wmax = 0.0;
    for (Eigen::Index i = 0; i < poles.size(); ++i) {
        if (!(poles[i].real() < 0.0)) r.stable = false;
        const double m = std::abs(poles[i]);
        if (m > 0.0) {
            wmin = std::min(wmin, m);
            wmax = std::max(wmax, m);
        }
    }
    // Frequency scaling s = w0 s~ (a power of two): A/w0, B/w0.
    const double w0 = wmax > 0.0 ? std::ldexp(1.0, static_cast<int>(std::lround(std::log2(std::sqrt(wmin * wmax)))))
                                 : 1.0;
    g.A /= w0;
    g.B /= w0;
    // Lower bound: ∞, 0, the poles' magnitudes and imaginary parts, a coarse grid.
    double lb = dnorm, wpk = kInf;
    auto probe = [&](double w) {
        const double v = sigma_max(g, w);
        if (v > lb) {
            lb = v;
            wpk = w;
        }
    };
    probe(0.0);
    for (Eigen::Index i = 0; i < poles.size(); ++i) {
        probe(std::abs(poles[i]) / w0);
        if (poles[i].imag() > 0.0) probe(poles[i].imag() / w0);
    }
    const double glo = std::log10(std::max(wmin, 1e-300) / w0) - 2.0, ghi = std::log10(std::max(wmax, 1e-300) / w0) + 2.0;
    for (int k = 0; k <= 200; ++k) probe(std::pow(10.0, glo + (ghi - glo) * k / 200.0));
    if (!std::isfinite(lb)) {
        r.norm = r.upper = kInf;
        r.peak_w_rad_s = wpk * w0;
        return r;
    }
    double upper = lb;
    for (int it = 0; it < 60; ++it) {
        const double gamma = (1.0 + 2.0 * rel_tol) * lb;
        if (gamma <= 0.0) break;
        const std::vector<double> w = crossings(g, gamma);
        upper = gamma;
        bool raised = false;
        for (std::size_t i = 0; i + 1 < w.size(); ++i) {
            const double mid = w[i] > 0.0 ? std::sqrt(w[i] * w[i + 1]) : 0.5 * w[i + 1];
            const double v = sigma_max(g, mid);
            if (v > gamma) raised = true;
            if (v > lb) {
                lb = v;
                wpk = mid;
            }
        }
        if (!raised) break;
    }
    r.norm = lb;
    r.upper = std::max(upper, lb);
    r.peak_w_rad_s = std::isfinite(wpk) ? wpk * w0 : kInf;
    return r;
}

}  // namespace piezoloop::design
