#include "ident/pi_fit.hpp"

#include <algorithm>
#include <cmath>
#include <limits>
#include <sstream>
#include <stdexcept>

#include "ident/csv_data.hpp"
#include "piezoloop/pi_inverse.hpp"
#include "status_text.hpp"

namespace piezoloop::design {
namespace {

std::string num(double v) {
    std::ostringstream s;
    s << v;
    return s.str();
}

// Columns scaled to unit RMS; returns the scales.
Eigen::VectorXd normalise_columns(Eigen::MatrixXd& m) {
    Eigen::VectorXd rms = (m.colwise().squaredNorm() / static_cast<double>(m.rows())).cwiseSqrt().transpose();
    for (int c = 0; c < m.cols(); ++c)
        if (rms(c) > 0.0) m.col(c) /= rms(c);
    return rms;
}

}  // namespace

std::vector<double> play_regressor(std::span<const double> u, double r) {
    std::vector<double> w(u.size());
    double state = 0.0;
    for (std::size_t k = 0; k < u.size(); ++k) {
        state = std::max(u[k] - r, std::min(u[k] + r, state));
        w[k] = state;
    }
    return w;
}

std::vector<double> pi_fit_thresholds(std::span<const double> u, const PiFitOptions& o) {
    std::vector<double> r;
    if (!o.thresholds.empty()) {
        if (o.thresholds.size() > static_cast<std::size_t>(kMaxPlayOperators))
            throw std::invalid_argument("thresholds: at most 16 play operators (the linear term p0 is extra)");
        for (std::size_t j = 0; j < o.thresholds.size(); ++j) {
            const double t = o.thresholds[j];
            const std::string f = "thresholds[" + std::to_string(j) + "]";
            if (!std::isfinite(t) || !(t > 0.0))
                throw std::invalid_argument(f + ": must be finite and > 0 (threshold 0 is the linear term p0)");
            if (j > 0 && !(t > o.thresholds[j - 1]))
                throw std::invalid_argument(f + ": thresholds must be strictly ascending");
        }
        return o.thresholds;
    }
    if (o.operators < 1 || o.operators > kMaxPlayOperators)
        throw std::invalid_argument("operators: must be in [1, 16] (PiModel holds 16 play operators)");
    double reach = 0.0;
    for (double v : u) reach = std::max(reach, std::fabs(v));
    double step = reach / (o.operators + 1);
    if (o.grid == ThresholdGrid::kShan && o.rho != 0.0) {
        if (!std::isfinite(o.rho) || !(o.rho > 0.0)) throw std::invalid_argument("rho: must be finite and > 0");
        step = o.rho;
    }
    if (!(step > 0.0)) throw std::invalid_argument(o.input_name + ": no excitation: the input is zero throughout");
    for (int j = 1; j <= o.operators; ++j) r.push_back(step * j);
    return r;
}

std::vector<double> nnls(const Eigen::MatrixXd& A, const Eigen::VectorXd& b, int max_iterations) {
    const int n = static_cast<int>(A.cols());
    if (max_iterations <= 0) max_iterations = 3 * n + 30;
    Eigen::VectorXd x = Eigen::VectorXd::Zero(n);
    std::vector<bool> passive(static_cast<std::size_t>(n), false);
    const double tol = 10.0 * std::numeric_limits<double>::epsilon() * A.cwiseAbs().colwise().sum().maxCoeff() *
                       std::max(A.rows(), A.cols());
    auto solve_passive = [&](Eigen::VectorXd& s) {
        std::vector<int> idx;
        for (int j = 0; j < n; ++j)
            if (passive[static_cast<std::size_t>(j)]) idx.push_back(j);
        Eigen::MatrixXd ap(A.rows(), static_cast<int>(idx.size()));
        for (std::size_t i = 0; i < idx.size(); ++i) ap.col(static_cast<int>(i)) = A.col(idx[i]);
        const Eigen::VectorXd sp = ap.colPivHouseholderQr().solve(b);
        s.setZero(n);
        for (std::size_t i = 0; i < idx.size(); ++i) s(idx[i]) = sp(static_cast<int>(i));
    };
    for (int outer = 0; outer < max_iterations; ++outer) {
        const Eigen::VectorXd w = A.transpose() * (b - A * x);
        int t = -1;
        double wmax = tol;
        for (int j = 0; j < n; ++j)
            if (!passive[static_cast<std::size_t>(j)] && w(j) > wmax) {
                wmax = w(j);
                t = j;
            }
        if (t < 0) break;  // KKT: every free gradient component <= tol
        passive[static_cast<std::size_t>(t)] = true;
        Eigen::VectorXd s;
        for (int inner = 0; inner <= n; ++inner) {
            solve_passive(s);
            double smin = std::numeric_limits<double>::infinity();
            for (int j = 0; j < n; ++j)
                if (passive[static_cast<std::size_t>(j)]) smin = std::min(smin, s(j));
            if (smin > 0.0) {
                x = s;
                break;
            }
            // Step from x towards s until the first passive variable hits 0,
            // and release the variables that did.
            double alpha = 1.0;
            for (int j = 0; j < n; ++j)
                if (passive[static_cast<std::size_t>(j)] && s(j) <= 0.0)
                    alpha = std::min(alpha, x(j) / (x(j) - s(j)));
            x += alpha * (s - x);
            bool any = false;
            for (int j = 0; j < n; ++j) {
                if (passive[static_cast<std::size_t>(j)] && x(j) <= tol) {
                    passive[static_cast<std::size_t>(j)] = false;
                    x(j) = 0.0;
                }
                any = any || passive[static_cast<std::size_t>(j)];
            }
            if (!any) break;
        }
    }
    return std::vector<double>(x.data(), x.data() + n);
}

PiFitResult fit_pi(std::span<const double> u, std::span<const double> y, const PiFitOptions& o) {
    if (u.size() != y.size())
        throw std::invalid_argument(o.output_name + ": has " + std::to_string(y.size()) + " samples but " +
                                    o.input_name + " has " + std::to_string(u.size()));
    require_finite(u, o.input_name);
    require_finite(y, o.output_name);
    const std::vector<double> r = pi_fit_thresholds(u, o);
    const int n = static_cast<int>(r.size());
    const int need = std::max(3 * (n + 1), 20);
    if (static_cast<int>(u.size()) < need)
        throw std::invalid_argument(o.input_name + ": too short: " + std::to_string(u.size()) + " samples; " +
                                    std::to_string(n + 1) + " weights need at least " + std::to_string(need));
    const auto [umin, umax] = std::minmax_element(u.begin(), u.end());
    if (!(*umax > *umin)) throw std::invalid_argument(o.input_name + ": no excitation: the input is constant");
    const auto [ymin, ymax] = std::minmax_element(y.begin(), y.end());

    const int rows = static_cast<int>(u.size());
    Eigen::MatrixXd phi(rows, n + 1);
    for (int k = 0; k < rows; ++k) phi(k, 0) = u[static_cast<std::size_t>(k)];
    for (int j = 0; j < n; ++j) {
        const std::vector<double> w = play_regressor(u, r[static_cast<std::size_t>(j)]);
        bool moved = false;
        for (int k = 0; k < rows; ++k) {
            phi(k, j + 1) = w[static_cast<std::size_t>(k)];
            moved = moved || w[static_cast<std::size_t>(k)] != 0.0;
        }
        if (!moved) {
            double reach = 0.0;
            for (double v : u) reach = std::max(reach, std::fabs(v));
            throw std::invalid_argument("thresholds[" + std::to_string(j) + "]: " + num(r[static_cast<std::size_t>(j)]) +
                                        " is never reached by " + o.input_name + " (max |" + o.input_name +
                                        "| = " + num(reach) + "): its play output is zero, weight undetermined");
        }
    }
    const Eigen::VectorXd target = Eigen::Map<const Eigen::VectorXd>(y.data(), rows);

    PiFitResult res;
    res.thresholds = r;

    // Conditioning of the normalised regressors (unique weights).
    Eigen::MatrixXd phin = phi;
    const Eigen::VectorXd scale = normalise_columns(phin);
    Eigen::HouseholderQR<Eigen::MatrixXd> qr(phin);
    const Eigen::MatrixXd rf = qr.matrixQR().topRows(n + 1).triangularView<Eigen::Upper>();
    Eigen::JacobiSVD<Eigen::MatrixXd> svd(rf, Eigen::ComputeFullV);
    const Eigen::VectorXd sv = svd.singularValues();
    res.regressor_condition =
        sv(n) > 0.0 ? sv(0) / sv(n) : std::numeric_limits<double>::infinity();
    if (!(res.regressor_condition <= 1e10)) {
        const Eigen::VectorXd v = svd.matrixV().col(n);
        const double vmax = v.cwiseAbs().maxCoeff();
        std::string dep;
        for (int c = 0; c <= n; ++c)
            if (std::fabs(v(c)) >= 0.1 * vmax)
                dep += (dep.empty() ? "" : ", ") +
                       (c == 0 ? std::string("p0") : "r=" + num(r[static_cast<std::size_t>(c - 1)]));
        throw std::invalid_argument(o.input_name + ": play regressors are linearly dependent (condition number " +
                                    num(res.regressor_condition) +
                                    " > 1e10): the input's reversals do not separate the operators " + dep +
                                    "; use fewer operators or an input with more distinct turning points");
    }

    Eigen::VectorXd p(n + 1);
    if (!o.monotone) {
        const Eigen::VectorXd c = qr.householderQ().transpose() * target;
        const Eigen::VectorXd pn = rf.triangularView<Eigen::Upper>().solve(c.head(n + 1));
        p = pn.cwiseQuotient(scale);
    } else {
        double m = o.min_slope;
        if (m < 0.0) m = 1e-3 * (*ymax - *ymin) / (*umax - *umin);
        if (!std::isfinite(m)) throw std::invalid_argument("min_slope: must be finite");
        if (!(m > 0.0))
            throw std::invalid_argument("min_slope: must be > 0 for an invertible model (or < 0 for automatic), and " +
                                        o.output_name + " must not be constant for the automatic value");
        res.min_slope = m;
        // psi = phi * D: column j = phi_j - phi_{j+1}, last = phi_n.
        Eigen::MatrixXd psi(rows, n + 1);
        for (int j = 0; j < n; ++j) psi.col(j) = phi.col(j) - phi.col(j + 1);
        psi.col(n) = phi.col(n);
        const Eigen::VectorXd b = target - m * psi.rowwise().sum();
        Eigen::MatrixXd psin = psi;
        const Eigen::VectorXd ps = normalise_columns(psin);
        for (int j = 0; j <= n; ++j)
            if (!(ps(j) > 0.0))
                throw std::invalid_argument(o.input_name + ": slope regressor " + std::to_string(j) +
                                            " is zero: operators " + std::to_string(j) + " and " +
                                            std::to_string(j + 1) + " are indistinguishable on this input");
        Eigen::HouseholderQR<Eigen::MatrixXd> qp(psin);
        const Eigen::MatrixXd rp = qp.matrixQR().topRows(n + 1).triangularView<Eigen::Upper>();
        const Eigen::VectorXd cp = (qp.householderQ().transpose() * b).head(n + 1);
        const std::vector<double> sol = nnls(rp, cp);
        Eigen::VectorXd slopes(n + 1);
        for (int j = 0; j <= n; ++j) {
            slopes(j) = m + sol[static_cast<std::size_t>(j)] / ps(j);
            if (sol[static_cast<std::size_t>(j)] == 0.0) ++res.active_constraints;
        }
        p(0) = slopes(0);
        for (int j = 1; j <= n; ++j) p(j) = slopes(j) - slopes(j - 1);
    }
    res.weights.assign(p.data(), p.data() + n + 1);
    double slope = 0.0;
    for (int j = 0; j <= n; ++j) {
        slope += p(j);
        res.slopes.push_back(slope);
    }

    PiModel& mdl = res.model;
    mdl.p0 = static_cast<float>(p(0));
    mdl.count = n;
    for (int j = 0; j < n; ++j) {
        mdl.thresholds[static_cast<std::size_t>(j)] = static_cast<float>(r[static_cast<std::size_t>(j)]);
        mdl.weights[static_cast<std::size_t>(j)] = static_cast<float>(p(j + 1));
    }
    if (const Status st = validate(mdl); !st.ok())
        throw std::invalid_argument("fitted model not representable in float: " + describe(st));
    PiModel inv;
    const Status st = invert_pi(mdl, inv);
    res.invertible = st.ok();
    res.invertibility = st.ok() ? "ok" : describe(st);

    // Errors of the float model as the core evaluates it.
    PiOperator<float> op;
    op.configure(mdl);
    double e2 = 0.0, emax = 0.0, mean = 0.0, d2 = 0.0;
    for (double v : y) mean += v;
    mean /= rows;
    for (int k = 0; k < rows; ++k) {
        const double e = y[static_cast<std::size_t>(k)] - op.apply(static_cast<float>(u[static_cast<std::size_t>(k)]));
        e2 += e * e;
        emax = std::max(emax, std::fabs(e));
        d2 += (y[static_cast<std::size_t>(k)] - mean) * (y[static_cast<std::size_t>(k)] - mean);
    }
    res.rms_error = std::sqrt(e2 / rows);
    res.max_error = emax;
    res.nrmse_percent = d2 > 0.0 ? 100.0 * std::sqrt(e2 / d2) : std::numeric_limits<double>::infinity();
    return res;
}

}  // namespace piezoloop::design
