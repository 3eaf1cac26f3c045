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

// Least squares without the regressor matrix: the rows of [Φ | y] are
// folded in blocks into the triangular factor R of a QR decomposition
// (sequential row updating: Björck, Numerical Methods for Least Squares
// Problems, SIAM 1996, §2.4.3; Golub & Van Loan §6.5), so memory is
// O(columns²) whatever the number of rows, and the result is that of one QR
// of the whole matrix (Householder QR of [R; block] keeps R's row space).
// Column scaling commutes with QR (Φ S⁻¹ = Q (R S⁻¹)), so the normalised
// regressors of the conditioning check need no second pass.
class RowFolder {
public:
    explicit RowFolder(int cols)
        : r_(Eigen::MatrixXd::Zero(cols, cols)), staging_(kBlockRows, cols) {}
    // The next row to fill (cols values); folded in when the block is full.
    double* next_row() {
        if (filled_ == kBlockRows) fold();
        return staging_.row(filled_++).data();
    }
    const Eigen::MatrixXd& r() {
        fold();
        return r_;
    }

private:
    static constexpr int kBlockRows = 4096;
    using RowMajor = Eigen::Matrix<double, Eigen::Dynamic, Eigen::Dynamic, Eigen::RowMajor>;
    void fold() {
        if (filled_ == 0) return;
        const Eigen::Index c = r_.cols();
        Eigen::MatrixXd stacked(c + filled_, c);
        stacked.topRows(c) = r_;
        stacked.bottomRows(filled_) = staging_.topRows(filled_);
        const Eigen::HouseholderQR<Eigen::MatrixXd> qr(stacked);
        r_ = qr.matrixQR().topRows(c).triangularView<Eigen::Upper>();
        filled_ = 0;
    }
    Eigen::MatrixXd r_;
    RowMajor staging_;
    int filled_ = 0;
};

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
    if (o.first_fitted >= u.size())
        throw std::invalid_argument("first_fitted: " + std::to_string(o.first_fitted) + " is not below the " +
                                    std::to_string(u.size()) + " samples");
    if (static_cast<int>(u.size() - o.first_fitted) < need)
        throw std::invalid_argument(o.input_name + ": too short: " + std::to_string(u.size() - o.first_fitted) +
                                    " fitted samples; " +
                                    std::to_string(n + 1) + " weights need at least " + std::to_string(need));
    const auto [umin, umax] = std::minmax_element(u.begin(), u.end());
    if (!(*umax > *umin)) throw std::invalid_argument(o.input_name + ": no excitation: the input is constant");
    const auto [ymin, ymax] = std::minmax_element(y.begin(), y.end());

    // [u, play_1(u) .. play_n(u), y] row by row into R (RowFolder): the
    // regressors Φ are R's first n + 1 columns, Qᵀy's head its last.
    const int first = static_cast<int>(o.first_fitted);
    const int all = static_cast<int>(u.size()), rows = all - first;
    RowFolder folder(n + 2);
    std::vector<double> play(static_cast<std::size_t>(n), 0.0);
    std::vector<bool> moved(static_cast<std::size_t>(n), false);
    for (int k = 0; k < all; ++k) {
        const double uk = u[static_cast<std::size_t>(k)];
        if (k < first) {
            for (std::size_t j = 0; j < play.size(); ++j) play[j] = std::max(uk - r[j], std::min(uk + r[j], play[j]));
            continue;
        }
        double* row = folder.next_row();
        row[0] = uk;
        for (std::size_t j = 0; j < play.size(); ++j) {
            play[j] = std::max(uk - r[j], std::min(uk + r[j], play[j]));  // play_regressor's recursion
            row[j + 1] = play[j];
            if (play[j] != 0.0) moved[j] = true;
        }
        row[n + 1] = y[static_cast<std::size_t>(k)];
        if (o.progress && (k & 0xFFFFF) == 0xFFFFF)
            o.progress("regressors: " + std::to_string((k + 1) >> 20) + " Mi of " + std::to_string(rows >> 20) +
                       " Mi rows");
    }
    for (int j = 0; j < n; ++j) {
        if (moved[static_cast<std::size_t>(j)]) continue;
        double reach = 0.0;
        for (double v : u) reach = std::max(reach, std::fabs(v));
        throw std::invalid_argument("thresholds[" + std::to_string(j) + "]: " + num(r[static_cast<std::size_t>(j)]) +
                                    " is never reached by " + o.input_name + " (max |" + o.input_name +
                                    "| = " + num(reach) + "): its play output is zero, weight undetermined");
    }
    const Eigen::MatrixXd& rall = folder.r();
    const Eigen::MatrixXd rphi = rall.topLeftCorner(n + 1, n + 1);
    const Eigen::VectorXd qty = rall.col(n + 1).head(n + 1);
    const double sqrt_rows = std::sqrt(static_cast<double>(rows));

    PiFitResult res;
    res.thresholds = r;

    // Conditioning of the regressors scaled to unit RMS (unique weights).
    Eigen::VectorXd scale = rphi.colwise().norm().transpose() / sqrt_rows;
    for (int j = 0; j <= n; ++j)
        if (!(scale(j) > 0.0)) scale(j) = 1.0;
    const Eigen::MatrixXd rf = rphi * scale.cwiseInverse().asDiagonal();
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
        const Eigen::VectorXd pn = rf.triangularView<Eigen::Upper>().solve(qty);
        p = pn.cwiseQuotient(scale);
    } else {
        double m = o.min_slope;
        if (m < 0.0) m = 1e-3 * (*ymax - *ymin) / (*umax - *umin);
        if (!std::isfinite(m)) throw std::invalid_argument("min_slope: must be finite");
        if (!(m > 0.0))
            throw std::invalid_argument("min_slope: must be > 0 for an invertible model (or < 0 for automatic), and " +
                                        o.output_name + " must not be constant for the automatic value");
        res.min_slope = m;
        // Slopes as unknowns: psi = Φ D, column j = phi_j - phi_{j+1}, last =
        // phi_n; in R's coordinates psi = Q (R D) and the target y - m psi 1
        // is Qᵀy - m (R D) 1 (the part of y outside Q's span is a constant of
        // the problem).
        Eigen::MatrixXd d = Eigen::MatrixXd::Identity(n + 1, n + 1);
        for (int j = 0; j < n; ++j) d(j + 1, j) = -1.0;
        const Eigen::MatrixXd rpsi = rphi * d;
        const Eigen::VectorXd b = qty - m * rpsi.rowwise().sum();
        const Eigen::VectorXd ps = rpsi.colwise().norm().transpose() / sqrt_rows;
        for (int j = 0; j <= n; ++j)
            if (!(ps(j) > 0.0))
                throw std::invalid_argument(o.input_name + ": slope regressor " + std::to_string(j) +
                                            " is zero: operators " + std::to_string(j) + " and " +
                                            std::to_string(j + 1) + " are indistinguishable on this input");
        const std::vector<double> sol = nnls(rpsi * ps.cwiseInverse().asDiagonal(), b);
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
    for (int k = first; k < all; ++k) mean += y[static_cast<std::size_t>(k)];
    mean /= rows;
    for (int k = 0; k < all; ++k) {
        if (o.progress && (k & 0xFFFFF) == 0xFFFFF)
            o.progress("model errors: " + std::to_string((k + 1) >> 20) + " Mi of " + std::to_string(rows >> 20) +
                       " Mi rows");
        const double e = y[static_cast<std::size_t>(k)] - op.apply(static_cast<float>(u[static_cast<std::size_t>(k)]));
        if (k < first) continue;
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
