#include "measure/tf_fit.hpp"

#include <algorithm>
#include <cmath>
#include <stdexcept>
#include <string>

#include <Eigen/Dense>

#include "lti/freqresp.hpp"
#include "lti/lti_convert.hpp"

namespace piezoloop::measure {

using design::cplx;

namespace {

// Weighted linear least squares over complex rows, real and imaginary parts
// stacked; columns scaled to unit norm so the rank test sees the data, not
// the units. Throws when the problem is rank-deficient.
Eigen::VectorXd solve_ls(const Eigen::MatrixXcd& a, const Eigen::VectorXcd& b) {
    const Eigen::Index m = a.rows(), n = a.cols();
    Eigen::MatrixXd ar(2 * m, n);
    Eigen::VectorXd br(2 * m);
    ar.topRows(m) = a.real();
    ar.bottomRows(m) = a.imag();
    br.head(m) = b.real();
    br.tail(m) = b.imag();
    Eigen::VectorXd scale(n);
    for (Eigen::Index j = 0; j < n; ++j) {
        const double c = ar.col(j).norm();
        scale(j) = c > 0.0 ? 1.0 / c : 1.0;
        ar.col(j) *= scale(j);
    }
    Eigen::ColPivHouseholderQR<Eigen::MatrixXd> qr(ar);
    qr.setThreshold(1e-11);
    if (qr.rank() < n)
        throw std::invalid_argument("--order: the least-squares problem is singular (rank " + std::to_string(qr.rank()) +
                                    " of " + std::to_string(n) +
                                    " coefficients): the data cannot tell this many poles and zeros apart; lower the order");
    return qr.solve(br).cwiseProduct(scale);
}

struct Basis {
    std::vector<cplx> x;     // q = e^{-j w Ts} (discrete) or s / w_ref (continuous)
    std::vector<cplx> g;     // measurement with the delay removed
    std::vector<double> w;   // weights
};

cplx power(cplx x, int n) {
    cplx r = 1.0;
    for (int i = 0; i < n; ++i) r *= x;
    return r;
}

// A(x): discrete 1 + sum a_n q^n (a = a1..aN); continuous x^N + sum_{n<N} a_n x^n (a = a0..a_{N-1}).
cplx eval_a(const Eigen::VectorXd& a, cplx x, bool continuous) {
    const int n = static_cast<int>(a.size());
    cplx r = continuous ? power(x, n) : 1.0;
    for (int i = 0; i < n; ++i) r += a(i) * power(x, continuous ? i : i + 1);
    return r;
}

// B alone, A fixed: rows sqrt(w) / |A| [x^0 .. x^M] b = sqrt(w) / |A| G A.
Eigen::VectorXd fit_b(const Basis& d, const Eigen::VectorXd& a, int zeros, bool continuous) {
    const Eigen::Index rows = static_cast<Eigen::Index>(d.x.size());
    Eigen::MatrixXcd m(rows, zeros + 1);
    Eigen::VectorXcd rhs(rows);
    for (Eigen::Index i = 0; i < rows; ++i) {
        const cplx ax = eval_a(a, d.x[static_cast<size_t>(i)], continuous);
        const double s = std::sqrt(d.w[static_cast<size_t>(i)]) / std::abs(ax);
        for (int k = 0; k <= zeros; ++k) m(i, k) = s * power(d.x[static_cast<size_t>(i)], k);
        rhs(i) = s * d.g[static_cast<size_t>(i)] * ax;
    }
    return solve_ls(m, rhs);
}

}  // namespace

std::vector<cplx> tf_fit_response(const TfFit& fit, const std::vector<double>& f_Hz) {
    std::vector<cplx> out;
    for (const double f : f_Hz) {
        const double w = 2.0 * M_PI * f;
        cplx h = design::evaluate(fit.model, design::frequency_point(w, fit.model.ts));
        if (fit.model.ts == 0.0 && fit.delay_s > 0.0) h *= std::polar(1.0, -w * fit.delay_s);
        out.push_back(h);
    }
    return out;
}

TfFit fit_tf(const std::vector<double>& f_Hz, const std::vector<cplx>& g, const std::vector<double>& var,
             const TfFitOptions& o) {
    const int N = o.poles, M = o.zeros, K = o.delay_samples;
    if (N < 1 || N > 40) throw std::invalid_argument("--order: poles must be in [1, 40]");
    if (M < 0 || M > 40) throw std::invalid_argument("--order: zeros must be in [0, 40]");
    if (o.continuous && M > N) throw std::invalid_argument("--order: a continuous model needs zeros <= poles");
    if (K < 0 || K > 1000) throw std::invalid_argument("--delay-samples: must be in [0, 1000]");
    if (!(o.ts > 0.0)) throw std::invalid_argument("frf: the sample period must be > 0");
    if (f_Hz.size() != g.size() || (!var.empty() && var.size() != g.size()))
        throw std::invalid_argument("frf: frequency_Hz, response and std_db must have the same length");
    const int params = N + M + 1;
    if (params > static_cast<int>(f_Hz.size()))
        throw std::invalid_argument("--order: " + std::to_string(params) + " coefficients (" + std::to_string(N) +
                                    " poles, " + std::to_string(M) + " zeros, gain) from " +
                                    std::to_string(f_Hz.size()) + " measured lines: the data cannot support it");
    const double w_ref = 2.0 * M_PI * *std::max_element(f_Hz.begin(), f_Hz.end());
    Basis d;
    std::vector<double> valid;
    for (const double v : var)
        if (std::isfinite(v) && v > 0.0) valid.push_back(v);
    double median_w = 1.0;
    if (!valid.empty()) {
        std::nth_element(valid.begin(), valid.begin() + static_cast<std::ptrdiff_t>(valid.size() / 2), valid.end());
        median_w = 1.0 / valid[valid.size() / 2];
    }
    for (size_t i = 0; i < f_Hz.size(); ++i) {
        const double w = 2.0 * M_PI * f_Hz[i];
        if (!(f_Hz[i] > 0.0) || !std::isfinite(g[i].real()) || !std::isfinite(g[i].imag()))
            throw std::invalid_argument("frf: line " + std::to_string(i) + ": frequency must be > 0 and response finite");
        d.x.push_back(o.continuous ? cplx(0.0, w / w_ref) : std::polar(1.0, -w * o.ts));
        d.g.push_back(g[i] * std::polar(1.0, w * o.ts * K));  // the delay taken out
        d.w.push_back(!var.empty() && std::isfinite(var[i]) && var[i] > 0.0 ? 1.0 / var[i] : median_w);
    }
    const double w_norm = median_w;  // weights relative to the median: conditioning only
    for (double& w : d.w) w /= w_norm;

    // Sanathanan–Koerner iterations.
    const Eigen::Index rows = static_cast<Eigen::Index>(d.x.size());
    Eigen::VectorXd a = Eigen::VectorXd::Zero(N), b;
    if (o.continuous) a(0) = 1.0;  // A_0 only scales the first iteration's rows: any stable start
    std::vector<double> inv_a(d.x.size(), 1.0);
    TfFit fit;
    for (int it = 0; it < o.max_iterations; ++it) {
        Eigen::MatrixXcd m(rows, params);
        Eigen::VectorXcd rhs(rows);
        for (Eigen::Index i = 0; i < rows; ++i) {
            const size_t u = static_cast<size_t>(i);
            const double s = std::sqrt(d.w[u]) * inv_a[u];
            const cplx x = d.x[u], gi = d.g[u];
            for (int n = 0; n < N; ++n) m(i, n) = -s * gi * power(x, o.continuous ? n : n + 1);
            for (int k = 0; k <= M; ++k) m(i, N + k) = s * power(x, k);
            rhs(i) = s * gi * (o.continuous ? power(x, N) : 1.0);
        }
        const Eigen::VectorXd theta = solve_ls(m, rhs);
        const Eigen::VectorXd a_new = theta.head(N);
        b = theta.tail(M + 1);
        const double change = (a_new - a).norm() / std::max(1e-300, a_new.norm());
        a = a_new;
        fit.iterations = it + 1;
        for (size_t u = 0; u < d.x.size(); ++u) inv_a[u] = 1.0 / std::abs(eval_a(a, d.x[u], o.continuous));
        if (change < o.tolerance) break;
    }

    // Poles, reflected into the stable region where needed; then B refitted.
    std::vector<double> den;  // descending powers of z (discrete) or s / w_ref (continuous)
    den.push_back(1.0);
    for (int n = 0; n < N; ++n) den.push_back(o.continuous ? a(N - 1 - n) : a(n));
    std::vector<cplx> poles = design::poly_roots(den);
    for (cplx& p : poles) {
        if (!o.continuous && std::abs(p) > 1.0) {
            p = 1.0 / std::conj(p);
            ++fit.reflected;
        } else if (o.continuous && p.real() > 0.0) {
            p = -std::conj(p);
            ++fit.reflected;
        }
    }
    if (fit.reflected > 0) {
        den = design::poly_from_roots(poles);
        for (int n = 0; n < N; ++n) a(o.continuous ? N - 1 - n : n) = den[static_cast<size_t>(n + 1)] / den[0];
        b = fit_b(d, a, M, o.continuous);
    }

    // The model in descending powers.
    design::Tf& tf = fit.model;
    if (o.continuous) {
        // A(s / w_ref) w_ref^N is monic in s: coefficient of s^n is a_n w_ref^(N - n).
        tf.den.assign(static_cast<size_t>(N + 1), 0.0);
        tf.den[0] = 1.0;
        for (int n = 0; n < N; ++n) tf.den[static_cast<size_t>(N - n)] = a(n) * std::pow(w_ref, N - n);
        tf.num.assign(static_cast<size_t>(M + 1), 0.0);
        for (int k = 0; k <= M; ++k) tf.num[static_cast<size_t>(M - k)] = b(k) * std::pow(w_ref, N - k);
        tf.ts = 0.0;
        fit.delay_s = K * o.ts;
        for (cplx& p : poles) p *= w_ref;
    } else {
        // z^-K B(q) / A(q) times z^L / z^L, L = max(N, M + K).
        const int L = std::max(N, M + K);
        tf.den.assign(static_cast<size_t>(L + 1), 0.0);
        tf.den[0] = 1.0;
        for (int n = 1; n <= N; ++n) tf.den[static_cast<size_t>(n)] = a(n - 1);
        tf.num.assign(static_cast<size_t>(L + 1), 0.0);
        for (int k = 0; k <= M; ++k) tf.num[static_cast<size_t>(K + k)] = b(k);
        while (tf.num.size() > 1 && tf.num.front() == 0.0) tf.num.erase(tf.num.begin());
        tf.ts = o.ts;
        for (int extra = N; extra < L; ++extra) poles.push_back(0.0);
    }
    fit.poles = poles;

    // Fit error per decade, and the weighted residual.
    const std::vector<cplx> h = tf_fit_response(fit, f_Hz);
    double wsum = 0.0;
    for (size_t i = 0; i < f_Hz.size(); ++i) {
        const double rel = std::abs(h[i] - g[i]) / std::abs(g[i]);
        wsum += d.w[i] * w_norm * std::norm(h[i] - g[i]);
        const double lo = std::pow(10.0, std::floor(std::log10(f_Hz[i]) + 1e-12));
        if (fit.decades.empty() || fit.decades.back().from_Hz != lo) fit.decades.push_back({lo, 10.0 * lo});
        DecadeError& e = fit.decades.back();
        ++e.lines;
        e.rms_rel += rel * rel;
        e.max_rel = std::max(e.max_rel, rel);
        e.max_db = std::max(e.max_db, std::fabs(design::magnitude_db(h[i]) - design::magnitude_db(g[i])));
        e.max_deg = std::max(e.max_deg, std::fabs(std::remainder(std::arg(h[i] / g[i]), 2.0 * M_PI)) * 180.0 / M_PI);
    }
    for (DecadeError& e : fit.decades) e.rms_rel = std::sqrt(e.rms_rel / e.lines);
    fit.weighted_rms = std::sqrt(wsum / static_cast<double>(f_Hz.size()));
    return fit;
}

}  // namespace piezoloop::measure
