#include "synth/d_fit.hpp"

#include <algorithm>
#include <cmath>
#include <limits>
#include <stdexcept>

#include <Eigen/Dense>

namespace piezoloop::design {
namespace {

using Eigen::MatrixXd;
using Eigen::VectorXd;

// Parameters p = [log g, a_1..a_K (zeros), b_1..b_K (poles)], all logs.
struct Problem {
    VectorXd w2;     // ω²
    VectorXd logm;   // log m
    VectorXd sqrtw;  // √weight
    double log_lo = 0.0, log_hi = 0.0;  // where corner frequencies may go (logs)
};

VectorXd model(const Problem& pr, const VectorXd& p, int k) {
    VectorXd y = VectorXd::Constant(pr.w2.size(), p(0));
    for (int i = 0; i < k; ++i) {
        const double z2 = std::exp(2.0 * p(1 + i)), q2 = std::exp(2.0 * p(1 + k + i));
        y.array() += 0.5 * ((pr.w2.array() + z2).log() - (pr.w2.array() + q2).log());
    }
    return y;
}

double cost(const Problem& pr, const VectorXd& p, int k) {
    return (pr.sqrtw.array() * (model(pr, p, k) - pr.logm).array()).matrix().squaredNorm();
}

// Levenberg–Marquardt from p; corner frequencies are kept within
// [log_lo, log_hi] (beyond the samples a corner only changes the gain).
VectorXd levenberg_marquardt(const Problem& pr, VectorXd p, int k) {
    const Eigen::Index n = pr.w2.size(), np = 1 + 2 * k;
    double f = cost(pr, p, k), lambda = 1e-3;
    for (int it = 0; it < 200; ++it) {
        const VectorXd r = pr.sqrtw.array() * (model(pr, p, k) - pr.logm).array();
        MatrixXd j(n, np);
        j.col(0) = pr.sqrtw;
        for (int i = 0; i < k; ++i) {
            const double z2 = std::exp(2.0 * p(1 + i)), q2 = std::exp(2.0 * p(1 + k + i));
            j.col(1 + i) = pr.sqrtw.array() * (z2 / (pr.w2.array() + z2));
            j.col(1 + k + i) = -pr.sqrtw.array() * (q2 / (pr.w2.array() + q2));
        }
        const MatrixXd jtj = j.transpose() * j;
        const VectorXd g = j.transpose() * r;
        bool improved = false;
        for (int tries = 0; tries < 12 && !improved; ++tries) {
            MatrixXd h = jtj;
            h.diagonal().array() += lambda * (jtj.diagonal().array() + 1e-12);
            VectorXd q = p - h.ldlt().solve(g);
            for (Eigen::Index i = 1; i < np; ++i) q(i) = std::clamp(q(i), pr.log_lo, pr.log_hi);
            const double fq = cost(pr, q, k);
            if (std::isfinite(fq) && fq < f) {
                improved = (f - fq) > 1e-14 * (1.0 + f);
                p = q;
                f = fq;
                lambda = std::max(lambda / 5.0, 1e-12);
                if (!improved) return p;  // converged
            } else {
                lambda *= 8.0;
            }
        }
        if (!improved) break;
    }
    return p;
}

}  // namespace

DFit fit_d_scaling(const std::vector<double>& w_rad_s, const std::vector<double>& magnitude,
                   const std::vector<double>& weight, int order) {
    const std::size_t n = w_rad_s.size();
    if (magnitude.size() != n || (!weight.empty() && weight.size() != n))
        throw std::invalid_argument("d fit: frequencies, magnitudes and weights must have the same length");
    if (order < 0) throw std::invalid_argument("d fit: order must be >= 0");
    if (n < static_cast<std::size_t>(2 * order + 1))
        throw std::invalid_argument("d fit: " + std::to_string(n) + " samples for " + std::to_string(2 * order + 1) +
                                    " parameters (order " + std::to_string(order) + ")");
    Problem pr;
    pr.w2.resize(static_cast<Eigen::Index>(n));
    pr.logm.resize(pr.w2.size());
    pr.sqrtw.resize(pr.w2.size());
    double wmin = std::numeric_limits<double>::infinity(), wmax = 0.0;
    for (std::size_t i = 0; i < n; ++i) {
        const auto k = static_cast<Eigen::Index>(i);
        if (!(w_rad_s[i] > 0.0) || !std::isfinite(w_rad_s[i]))
            throw std::invalid_argument("d fit: frequency " + std::to_string(i) + " must be finite and > 0");
        if (!(magnitude[i] > 0.0) || !std::isfinite(magnitude[i]))
            throw std::invalid_argument("d fit: magnitude " + std::to_string(i) + " must be finite and > 0");
        const double wt = weight.empty() ? 1.0 : weight[i];
        if (!(wt >= 0.0) || !std::isfinite(wt)) throw std::invalid_argument("d fit: weights must be finite and >= 0");
        pr.w2(k) = w_rad_s[i] * w_rad_s[i];
        pr.logm(k) = std::log(magnitude[i]);
        pr.sqrtw(k) = std::sqrt(wt);
        wmin = std::min(wmin, w_rad_s[i]);
        wmax = std::max(wmax, w_rad_s[i]);
    }
    // Corners stay inside the sampled band: beyond it a corner only changes
    // the gain, and a far-off one (a zero of 1/d near s = 0, say) makes the
    // scaled plant nearly lose rank on the imaginary axis.
    pr.log_lo = std::log(wmin);
    pr.log_hi = std::log(wmax);
    const double wsum = pr.sqrtw.squaredNorm();
    if (!(wsum > 0.0)) throw std::invalid_argument("d fit: all weights are zero");

    // Order 0: the weighted mean of log m.
    VectorXd best(1);
    best(0) = (pr.sqrtw.array().square() * pr.logm.array()).sum() / wsum;
    double best_cost = cost(pr, best, 0);
    for (int k = 1; k <= order; ++k) {
        std::vector<VectorXd> starts;
        // (a) the previous fit plus a pair around the largest residual: a zero
        // below and a pole above it where the fit is too low, else swapped.
        const VectorXd res = model(pr, best, k - 1) - pr.logm;
        Eigen::Index at = 0;
        (pr.sqrtw.array() * res.array()).abs().maxCoeff(&at);
        const double lw = 0.5 * std::log(pr.w2(at));
        for (double sign : {1.0, -1.0}) {
            VectorXd p(1 + 2 * k);
            p(0) = best(0);
            for (int i = 0; i < k - 1; ++i) {
                p(1 + i) = best(1 + i);
                p(1 + k + i) = best(1 + (k - 1) + i);
            }
            const double shift = res(at) < 0.0 ? sign * 0.5 : -sign * 0.5;
            p(k) = std::clamp(lw - shift, pr.log_lo, pr.log_hi);          // new zero
            p(2 * k) = std::clamp(lw + shift, pr.log_lo, pr.log_hi);      // new pole
            starts.push_back(p);
        }
        // (b) zeros and poles interleaved over the sampled band, both ways round.
        for (int swap = 0; swap < 2; ++swap) {
            VectorXd p(1 + 2 * k);
            p(0) = best(0);
            const double a = std::log(wmin), b = std::log(wmax);
            for (int i = 0; i < 2 * k; ++i) {
                const double x = a + (b - a) * (i + 0.5) / (2.0 * k);
                const bool is_zero = ((i % 2) == 0) != (swap == 1);
                if (is_zero) p(1 + i / 2) = x;
                else p(1 + k + i / 2) = x;
            }
            starts.push_back(p);
        }
        VectorXd order_best;
        double order_cost = std::numeric_limits<double>::infinity();
        for (const VectorXd& s : starts) {
            const VectorXd p = levenberg_marquardt(pr, s, k);
            const double c = cost(pr, p, k);
            if (c < order_cost) {
                order_cost = c;
                order_best = p;
            }
        }
        if (order_cost <= best_cost) {
            best = order_best;
            best_cost = order_cost;
        } else {  // cannot happen in exact arithmetic (start (a) contains the lower order); keep k - 1 padded
            VectorXd p(1 + 2 * k);
            p(0) = best(0);
            for (int i = 0; i < k - 1; ++i) {
                p(1 + i) = best(1 + i);
                p(1 + k + i) = best(1 + (k - 1) + i);
            }
            p(k) = p(2 * k) = pr.log_hi;  // a cancelling pair
            best = p;
        }
    }
    DFit r;
    r.order = order;
    const int k = order;
    // |d(jω)| = g Π|jω + z| / Π|jω + p| with g = e^{p0}; the Zpk gain is g.
    r.d.gain = std::exp(best(0));
    for (int i = 0; i < k; ++i) {
        r.d.zeros.emplace_back(-std::exp(best(1 + i)), 0.0);
        r.d.poles.emplace_back(-std::exp(best(1 + k + i)), 0.0);
    }
    const VectorXd fit = model(pr, best, k);
    r.rms_log_error = std::sqrt(best_cost / wsum);
    const double wmax_weight = pr.sqrtw.array().square().maxCoeff();
    r.max_rel_error =
        (pr.sqrtw.array().square() / wmax_weight * ((fit - pr.logm).array().exp() - 1.0).abs()).maxCoeff();
    return r;
}

}  // namespace piezoloop::design
