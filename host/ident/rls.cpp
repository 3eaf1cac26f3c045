#include "ident/rls.hpp"

#include <algorithm>
#include <cmath>
#include <limits>
#include <sstream>
#include <stdexcept>

#include "ident/csv_data.hpp"
#include "lti/lti_convert.hpp"

namespace piezoloop::design {

Rls::Rls(const Eigen::VectorXd& initial_covariance_diagonal, double forgetting)
    : psi_(Eigen::VectorXd::Zero(initial_covariance_diagonal.size())),
      w_(initial_covariance_diagonal.asDiagonal()),
      lambda_(forgetting) {
    if (!(forgetting > 0.0 && forgetting <= 1.0))
        throw std::invalid_argument("forgetting: must be in (0, 1]");
}

double Rls::update(const Eigen::VectorXd& theta, double y) {
    const double e0 = y - psi_.dot(theta);
    const Eigen::VectorXd wt = w_ * theta;
    const double den = lambda_ + theta.dot(wt);
    // W theta after the update equals W theta / den (Sherman–Morrison), so
    // the parameter step uses wt / den directly.
    psi_ += wt * (e0 / den);
    w_ = (w_ - wt * wt.transpose() / den) / lambda_;
    // Keep W symmetric: rounding otherwise makes it drift over long runs.
    w_ = 0.5 * (w_ + w_.transpose()).eval();
    return e0;
}

namespace {

// 1 + a1 q^-1 + ... with every root outside the unit circle reflected to
// 1/conj(root): the same magnitude response up to a gain, and stable.
std::vector<double> stabilised(const std::vector<double>& a) {
    std::vector<double> poly{1.0};
    poly.insert(poly.end(), a.begin(), a.end());
    std::vector<cplx> r = poly_roots(poly);
    bool changed = false;
    for (cplx& z : r)
        if (std::abs(z) >= 1.0) {
            z = 1.0 / std::conj(z);
            changed = true;
        }
    if (!changed) return a;
    std::vector<double> p = poly_from_roots(r);
    return std::vector<double>(p.begin() + 1, p.end());
}

// y = u / (1 + a1 q^-1 + ...), zero initial state.
std::vector<double> all_pole_filter(const std::vector<double>& a, std::span<const double> u) {
    std::vector<double> y(u.size());
    for (std::size_t k = 0; k < u.size(); ++k) {
        double v = u[k];
        for (std::size_t i = 0; i < a.size() && i < k; ++i) v -= a[i] * y[k - 1 - i];
        y[k] = v;
    }
    return y;
}

struct Regression {
    Eigen::MatrixXd phi;  // rows x p
    Eigen::VectorXd target;
    std::vector<std::string> names;
};

Regression arx_regression(std::span<const double> u, std::span<const double> y, int na, int nb, int delay,
                          int n0, const LinearIdentSpec& spec) {
    const int n = static_cast<int>(u.size());
    const int rows = n - n0;
    Regression r;
    r.phi.resize(rows, na + nb);
    r.target.resize(rows);
    for (int k = n0; k < n; ++k) {
        const int row = k - n0;
        for (int i = 1; i <= na; ++i) r.phi(row, i - 1) = -y[static_cast<std::size_t>(k - i)];
        for (int j = 0; j < nb; ++j) r.phi(row, na + j) = u[static_cast<std::size_t>(k - delay - j)];
        r.target(row) = y[static_cast<std::size_t>(k)];
    }
    for (int i = 1; i <= na; ++i) r.names.push_back(spec.output_name + "[k-" + std::to_string(i) + "]");
    for (int j = 0; j < nb; ++j) {
        const int lag = delay + j;
        r.names.push_back(spec.input_name + (lag == 0 ? "[k]" : "[k-" + std::to_string(lag) + "]"));
    }
    return r;
}

// Column RMS of the regressors (for W0 and the conditioning check).
Eigen::VectorXd column_rms(const Eigen::MatrixXd& phi) {
    return (phi.colwise().squaredNorm() / static_cast<double>(phi.rows())).cwiseSqrt().transpose();
}

// Refuses regressors that cannot identify the parameters; returns the
// condition number of the column-normalised regressor matrix.
double check_regressors(const Regression& r, const LinearIdentSpec& spec) {
    const Eigen::VectorXd rms = column_rms(r.phi);
    for (int c = 0; c < rms.size(); ++c)
        if (!(rms(c) > 0.0)) {
            const bool is_input = c >= spec.na;
            throw std::invalid_argument((is_input ? spec.input_name : spec.output_name) + ": regressor " +
                                        r.names[static_cast<std::size_t>(c)] +
                                        " is zero throughout: no excitation");
        }
    const Eigen::MatrixXd normalised = r.phi * rms.cwiseInverse().asDiagonal();
    // Singular values of the normalised regressors via the R factor of a QR
    // (same singular values, small SVD).
    Eigen::HouseholderQR<Eigen::MatrixXd> qr(normalised);
    const Eigen::MatrixXd rf = qr.matrixQR().topRows(normalised.cols()).triangularView<Eigen::Upper>();
    Eigen::JacobiSVD<Eigen::MatrixXd> svd(rf, Eigen::ComputeFullV);
    const Eigen::VectorXd sv = svd.singularValues();
    const double cond = sv(sv.size() - 1) > 0.0 ? sv(0) / sv(sv.size() - 1)
                                                : std::numeric_limits<double>::infinity();
    if (!(cond <= 1e10)) {
        const Eigen::VectorXd nullv = svd.matrixV().col(sv.size() - 1);
        const double vmax = nullv.cwiseAbs().maxCoeff();
        std::string dependent;
        for (int c = 0; c < nullv.size(); ++c)
            if (std::fabs(nullv(c)) >= 0.1 * vmax)
                dependent += (dependent.empty() ? "" : ", ") + r.names[static_cast<std::size_t>(c)];
        std::ostringstream m;
        m << spec.input_name << ": regressors are linearly dependent (condition number " << cond
          << " > 1e10): the input does not excite the model (it must be persistently exciting of order na + nb = "
          << spec.na + spec.nb << "; a constant needs order 1, each sinusoid adds 2); dependent regressors: "
          << dependent;
        throw std::invalid_argument(m.str());
    }
    return cond;
}

Eigen::VectorXd run_rls(const Regression& r, const LinearIdentSpec& spec, double* prediction_rms) {
    const Eigen::VectorXd rms = column_rms(r.phi);
    const Eigen::VectorXd w0 = spec.initial_covariance * rms.cwiseProduct(rms).cwiseInverse();
    Rls rls(w0, spec.forgetting);
    for (int k = 0; k < r.phi.rows(); ++k) rls.update(r.phi.row(k).transpose(), r.target(k));
    const Eigen::VectorXd theta = rls.parameters();
    if (prediction_rms)
        *prediction_rms = std::sqrt((r.target - r.phi * theta).squaredNorm() / static_cast<double>(r.phi.rows()));
    return theta;
}

// Simulation with the first n0 outputs taken from the data.
std::vector<double> simulate_from(const std::vector<double>& a, const std::vector<double>& b, int delay,
                                  std::span<const double> u, std::span<const double> y, int n0) {
    std::vector<double> ys(u.size());
    for (int k = 0; k < static_cast<int>(u.size()); ++k) {
        const std::size_t ku = static_cast<std::size_t>(k);
        if (k < n0) {
            ys[ku] = y[ku];
            continue;
        }
        double v = 0.0;
        for (std::size_t i = 0; i < a.size(); ++i) v -= a[i] * ys[ku - 1 - i];
        for (std::size_t j = 0; j < b.size(); ++j) v += b[j] * u[ku - static_cast<std::size_t>(delay) - j];
        ys[ku] = v;
    }
    return ys;
}

void validate_spec(const LinearIdentSpec& s, double ts) {
    if (!(ts > 0.0) || !std::isfinite(ts)) throw std::invalid_argument("ts: sample period must be finite and > 0");
    if (s.na < 0 || s.na > 20) throw std::invalid_argument("na: must be in [0, 20]");
    if (s.nb < 1 || s.nb > 20) throw std::invalid_argument("nb: must be in [1, 20]");
    if (s.delay < 0 || s.delay > 1000) throw std::invalid_argument("delay: must be in [0, 1000]");
    if (!(s.forgetting > 0.0 && s.forgetting <= 1.0)) throw std::invalid_argument("forgetting: must be in (0, 1]");
    if (!(s.initial_covariance > 0.0) || !std::isfinite(s.initial_covariance))
        throw std::invalid_argument("initial_covariance: must be finite and > 0");
    if (s.max_iterations < 1 || s.max_iterations > 10000)
        throw std::invalid_argument("max_iterations: must be in [1, 10000]");
    if (!(s.tolerance > 0.0)) throw std::invalid_argument("tolerance: must be > 0");
    if (s.structure == LinearStructure::kOutputError && s.na < 1)
        throw std::invalid_argument("na: an output-error model needs at least one pole (na >= 1)");
}

}  // namespace

std::vector<double> simulate_arx(std::span<const double> a, std::span<const double> b, int delay,
                                 std::span<const double> u) {
    std::vector<double> y(u.size(), 0.0);
    for (std::size_t k = 0; k < u.size(); ++k) {
        double v = 0.0;
        for (std::size_t i = 0; i < a.size() && i < k; ++i) v -= a[i] * y[k - 1 - i];
        for (std::size_t j = 0; j < b.size(); ++j) {
            const std::size_t lag = static_cast<std::size_t>(delay) + j;
            if (lag <= k) v += b[j] * u[k - lag];
        }
        y[k] = v;
    }
    return y;
}

LinearIdentResult identify_linear(std::span<const double> u, std::span<const double> y, double ts,
                                  const LinearIdentSpec& spec) {
    validate_spec(spec, ts);
    if (u.size() != y.size())
        throw std::invalid_argument(spec.output_name + ": has " + std::to_string(y.size()) + " samples but " +
                                    spec.input_name + " has " + std::to_string(u.size()));
    require_finite(u, spec.input_name);
    require_finite(y, spec.output_name);
    const int n = static_cast<int>(u.size());
    const int p = spec.na + spec.nb;
    const int n0 = std::max(spec.na, spec.delay + spec.nb - 1);
    const int rows = n - n0;
    const int need = std::max(3 * p, 20);
    if (rows < need)
        throw std::invalid_argument(spec.input_name + ": too short: " + std::to_string(n) + " samples give " +
                                    std::to_string(std::max(rows, 0)) + " regression rows; " +
                                    std::to_string(p) + " parameters need at least " + std::to_string(need));
    const auto [umin, umax] = std::minmax_element(u.begin(), u.end());
    if (!(*umax > *umin))
        throw std::invalid_argument(spec.input_name + ": no excitation: the input is constant");
    const auto [ymin, ymax] = std::minmax_element(y.begin(), y.end());
    if (!(*ymax > *ymin))
        throw std::invalid_argument(spec.output_name + ": the output is constant: nothing to identify");

    LinearIdentResult res;
    Regression reg = arx_regression(u, y, spec.na, spec.nb, spec.delay, n0, spec);
    res.regressor_condition = check_regressors(reg, spec);
    Eigen::VectorXd theta = run_rls(reg, spec, &res.prediction_rms);
    res.method = "rls-arx";
    res.iterations = 1;

    auto split_theta = [&](const Eigen::VectorXd& th, std::vector<double>& a, std::vector<double>& b) {
        a.assign(th.data(), th.data() + spec.na);
        b.assign(th.data() + spec.na, th.data() + p);
    };
    split_theta(theta, res.a, res.b);

    if (spec.structure == LinearStructure::kOutputError) {
        res.method = "steiglitz-mcbride-oe";
        res.converged = false;
        for (int it = 1; it <= spec.max_iterations; ++it) {
            const std::vector<double> f = stabilised(res.a);
            const std::vector<double> uf = all_pole_filter(f, u);
            const std::vector<double> yf = all_pole_filter(f, y);
            const Regression rf = arx_regression(uf, yf, spec.na, spec.nb, spec.delay, n0, spec);
            const Eigen::VectorXd next = run_rls(rf, spec, &res.prediction_rms);
            const double step = (next - theta).norm();
            theta = next;
            split_theta(theta, res.a, res.b);
            res.iterations = it;
            if (step <= spec.tolerance * theta.norm()) {
                res.converged = true;
                break;
            }
        }
    }

    // Discrete Tf: multiply A and q^-d B by z^m, m = max(na, delay + nb - 1).
    const int m = n0;
    Tf tf;
    tf.ts = ts;
    tf.den.assign(static_cast<std::size_t>(m + 1), 0.0);
    tf.den[0] = 1.0;
    for (int i = 0; i < spec.na; ++i) tf.den[static_cast<std::size_t>(i + 1)] = res.a[static_cast<std::size_t>(i)];
    tf.num.assign(static_cast<std::size_t>(m + 1), 0.0);
    for (int j = 0; j < spec.nb; ++j)
        tf.num[static_cast<std::size_t>(spec.delay + j)] = res.b[static_cast<std::size_t>(j)];
    while (tf.num.size() > 1 && tf.num.front() == 0.0) tf.num.erase(tf.num.begin());
    res.model = tf;

    for (const cplx& z : poly_roots(tf.den))
        if (!(std::abs(z) < 1.0)) res.stable = false;

    const std::vector<double> ys = simulate_from(res.a, res.b, spec.delay, u, y, n0);
    double mean = 0.0;
    for (int k = n0; k < n; ++k) mean += y[static_cast<std::size_t>(k)];
    mean /= rows;
    double err2 = 0.0, dev2 = 0.0;
    for (int k = n0; k < n; ++k) {
        const std::size_t kk = static_cast<std::size_t>(k);
        err2 += (y[kk] - ys[kk]) * (y[kk] - ys[kk]);
        dev2 += (y[kk] - mean) * (y[kk] - mean);
    }
    res.simulation_rms = std::sqrt(err2 / rows);
    res.fit_percent = 100.0 * (1.0 - std::sqrt(err2 / dev2));
    if (!std::isfinite(res.fit_percent)) res.fit_percent = -std::numeric_limits<double>::infinity();
    res.samples_used = rows;
    return res;
}

}  // namespace piezoloop::design
