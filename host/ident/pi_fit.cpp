#include "ident/pi_fit.hpp"

#include <algorithm>
#include <cmath>
#include <limits>
#include <stdexcept>

#include "ident/csv_data.hpp"
#include "ident/dead_zone_map.hpp"
#include "piezoloop/pi_inverse.hpp"
#include "status_text.hpp"
#include "format/number.hpp"

namespace piezoloop::design {
namespace {

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
    if (o.fit_offset && !u.empty()) {
        const auto [lo, hi] = std::minmax_element(u.begin(), u.end());
        reach = 0.5 * (*hi - *lo);
    }
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


namespace {

// First sample from which the play of threshold r no longer depends on its
// state before the record; u.size() if that never happens.
std::size_t forgetting_sample(std::span<const double> u, double r) {
    double lo = u[0] - r, hi = u[0] + r;  // the extremes of any state after the first sample
    for (std::size_t k = 0; k < u.size(); ++k) {
        lo = std::max(u[k] - r, std::min(u[k] + r, lo));
        hi = std::max(u[k] - r, std::min(u[k] + r, hi));
        if (lo == hi) return k;
    }
    return u.size();
}

// min |M s - b| with s_i >= 0 where bounded[i], free otherwise: the free
// columns first in a QR, Lawson–Hanson NNLS on the trailing block, the free
// unknowns by back-substitution. Columns scaled to unit norm for the NNLS
// tolerance. Returns s; counts the bounds held at 0.
Eigen::VectorXd bounded_lsq(const Eigen::MatrixXd& m, const Eigen::VectorXd& b, const std::vector<bool>& bounded,
                            int& active) {
    const int k = static_cast<int>(m.cols());
    Eigen::VectorXd scale = m.colwise().norm().transpose();
    for (int j = 0; j < k; ++j)
        if (!(scale(j) > 0.0)) scale(j) = 1.0;
    std::vector<int> order;
    for (int j = 0; j < k; ++j)
        if (!bounded[static_cast<std::size_t>(j)]) order.push_back(j);
    const int nf = static_cast<int>(order.size());
    for (int j = 0; j < k; ++j)
        if (bounded[static_cast<std::size_t>(j)]) order.push_back(j);
    Eigen::MatrixXd ms(m.rows(), k);
    for (int i = 0; i < k; ++i) ms.col(i) = m.col(order[static_cast<std::size_t>(i)]) / scale(order[static_cast<std::size_t>(i)]);
    Eigen::VectorXd sol(k);
    active = 0;
    if (nf == k) {
        sol = ms.colPivHouseholderQr().solve(b);
    } else if (nf == 0) {
        const std::vector<double> x = nnls(ms, b);
        for (int i = 0; i < k; ++i) sol(i) = x[static_cast<std::size_t>(i)];
    } else {
        const Eigen::HouseholderQR<Eigen::MatrixXd> qr(ms);
        const Eigen::MatrixXd r = qr.matrixQR().topRows(k).triangularView<Eigen::Upper>();
        const Eigen::VectorXd qtb = (qr.householderQ().transpose() * b).head(k);
        const std::vector<double> x = nnls(r.bottomRightCorner(k - nf, k - nf), qtb.tail(k - nf));
        for (int i = nf; i < k; ++i) sol(i) = x[static_cast<std::size_t>(i - nf)];
        sol.head(nf) = r.topLeftCorner(nf, nf).triangularView<Eigen::Upper>().solve(
            qtb.head(nf) - r.topRightCorner(nf, k - nf) * sol.tail(k - nf));
    }
    Eigen::VectorXd s(k);
    for (int i = 0; i < k; ++i) {
        const int j = order[static_cast<std::size_t>(i)];
        s(j) = sol(i) / scale(j);
        if (i >= nf && sol(i) == 0.0) ++active;
    }
    return s;
}

void accumulate(FitErrors& e, double& sum_y, double& sum_y2, double err, double yk) {
    e.rms_error += err * err;
    e.max_error = std::max(e.max_error, std::fabs(err));
    sum_y += yk;
    sum_y2 += yk * yk;
    ++e.samples;
}

void finish(FitErrors& e, double sum_y, double sum_y2) {
    if (e.samples == 0) return;
    const double n = static_cast<double>(e.samples);
    const double e2 = e.rms_error;
    const double d2 = std::max(sum_y2 - sum_y * sum_y / n, 0.0);
    e.rms_error = std::sqrt(e2 / n);
    e.nrmse_percent = d2 > 0.0 ? 100.0 * std::sqrt(e2 / d2) : std::numeric_limits<double>::infinity();
}

}  // namespace

PiFitResult fit_pi(std::span<const double> u, std::span<const double> y, const PiFitOptions& o) {
    if (u.size() != y.size())
        throw std::invalid_argument(o.output_name + ": has " + std::to_string(y.size()) + " samples but " +
                                    o.input_name + " has " + std::to_string(u.size()));
    require_finite(u, o.input_name);
    require_finite(y, o.output_name);
    if (o.output_dead_zones < 0 || o.output_dead_zones > 8)
        throw std::invalid_argument("output_dead_zones: must be in [0, 8]");
    if (o.output_thresholds.size() > 8) throw std::invalid_argument("output_thresholds: at most 8 dead zones");
    for (std::size_t i = 0; i < o.output_thresholds.size(); ++i)
        if (!std::isfinite(o.output_thresholds[i]) || (i > 0 && !(o.output_thresholds[i] > o.output_thresholds[i - 1])))
            throw std::invalid_argument("output_thresholds[" + std::to_string(i) +
                                        "]: must be finite and strictly ascending");
    if (!(o.holdout >= 0.0 && o.holdout < 1.0)) throw std::invalid_argument("holdout: must be in [0, 1)");
    if (!(o.min_output_slope > 0.0) || !std::isfinite(o.min_output_slope))
        throw std::invalid_argument("min_output_slope: must be finite and > 0");
    if (!u.empty()) {
        const auto [lo, hi] = std::minmax_element(u.begin(), u.end());
        if (o.fit_offset && !(*hi > *lo))
            throw std::invalid_argument(o.input_name + ": no excitation: the input is constant");
    }
    const std::vector<double> r = pi_fit_thresholds(u, o);
    const int n = static_cast<int>(r.size());
    const int nz = o.output_thresholds.empty() ? o.output_dead_zones : static_cast<int>(o.output_thresholds.size());
    const int c0 = o.fit_offset ? 1 : 0;
    const int k = c0 + 1 + n + nz;  // unknowns
    const int need = std::max(3 * k, 20);
    const std::size_t all_samples = u.size();
    const std::size_t held = static_cast<std::size_t>(std::floor(o.holdout * static_cast<double>(all_samples)));
    const std::size_t vfrom = all_samples - held;
    std::size_t first_fitted = o.first_fitted;
    if (first_fitted == PiFitOptions::kAutoFirstFitted) {
        first_fitted = all_samples == 0 ? 0 : forgetting_sample(u, r.back());
        if (first_fitted >= vfrom)
            throw std::invalid_argument(
                "thresholds[" + std::to_string(n - 1) + "]: " + o.input_name + " never moves by 2 r = " +
                format::significant(2.0 * r.back()) + " in one direction" + (held ? " before the held-out samples" : "") +
                ", so this play's state before the record never stops mattering; give the first fitted "
                "sample (0: plays at rest at the start) or smaller thresholds");
    } else if (first_fitted >= vfrom) {
        throw std::invalid_argument("first_fitted: " + std::to_string(first_fitted) + " is not below the " +
                                    std::to_string(vfrom) + (held ? " samples before the held-out part" : " samples"));
    }
    if (static_cast<int>(vfrom - first_fitted) < need)
        throw std::invalid_argument(o.input_name + ": too short: " + std::to_string(vfrom - first_fitted) +
                                    " fitted samples; " + std::to_string(k) + " unknowns need at least " +
                                    std::to_string(need));
    const auto [umin, umax] = std::minmax_element(u.begin(), u.end());
    if (!(*umax > *umin)) throw std::invalid_argument(o.input_name + ": no excitation: the input is constant");
    const auto [ymin, ymax] = std::minmax_element(y.begin(), y.end());

    const int first = static_cast<int>(first_fitted);
    const int all = static_cast<int>(all_samples), vf = static_cast<int>(vfrom), rows = vf - first;
    // Dead-zone thresholds on the fitted outputs' range.
    std::vector<double> dz = o.output_thresholds;
    if (nz > 0 && dz.empty()) {
        const auto [fmin, fmax] = std::minmax_element(y.begin() + first, y.begin() + vf);
        if (!(*fmax > *fmin))
            throw std::invalid_argument(o.output_name + ": constant over the fitted samples: no output nonlinearity to fit");
        for (int i = 1; i <= nz; ++i) dz.push_back(*fmin + (*fmax - *fmin) * i / (nz + 1));
    }

    // [1, u, play_1(u) .. play_n(u), -dz_1(y) .. -dz_N(y), y] row by row into
    // R (RowFolder): the regressors Φ are R's first k columns, Qᵀy's head its last.
    RowFolder folder(k + 1);
    std::vector<double> play(static_cast<std::size_t>(n), 0.0);
    std::vector<bool> moved(static_cast<std::size_t>(n), false);
    for (int s = 0; s < vf; ++s) {
        const double uk = u[static_cast<std::size_t>(s)];
        if (s < first) {
            for (std::size_t j = 0; j < play.size(); ++j) play[j] = std::max(uk - r[j], std::min(uk + r[j], play[j]));
            continue;
        }
        const double yk = y[static_cast<std::size_t>(s)];
        double* row = folder.next_row();
        if (c0) row[0] = 1.0;
        row[c0] = uk;
        for (std::size_t j = 0; j < play.size(); ++j) {
            play[j] = std::max(uk - r[j], std::min(uk + r[j], play[j]));  // play_regressor's recursion
            row[c0 + 1 + static_cast<int>(j)] = play[j];
            if (play[j] != 0.0) moved[j] = true;
        }
        for (int i = 0; i < nz; ++i) row[c0 + 1 + n + i] = -std::max(yk - dz[static_cast<std::size_t>(i)], 0.0);
        row[k] = yk;
        if (o.progress && (s & 0xFFFFF) == 0xFFFFF)
            o.progress("regressors: " + std::to_string((s + 1) >> 20) + " Mi of " + std::to_string(rows >> 20) +
                       " Mi rows");
    }
    for (int j = 0; j < n; ++j) {
        if (moved[static_cast<std::size_t>(j)]) continue;
        double reach = 0.0;
        for (double v : u) reach = std::max(reach, std::fabs(v));
        throw std::invalid_argument("thresholds[" + std::to_string(j) + "]: " + format::significant(r[static_cast<std::size_t>(j)]) +
                                    " is never reached by " + o.input_name + " (max |" + o.input_name +
                                    "| = " + format::significant(reach) + "): its play output is zero, weight undetermined");
    }
    const Eigen::MatrixXd& rall = folder.r();
    const Eigen::MatrixXd rphi = rall.topLeftCorner(k, k);
    const Eigen::VectorXd qty = rall.col(k).head(k);
    const double sqrt_rows = std::sqrt(static_cast<double>(rows));

    PiFitResult res;
    res.thresholds = r;
    res.first_fitted = first_fitted;
    res.validated_from = vfrom;
    auto column_name = [&](int c) {
        if (c < c0) return std::string("offset");
        if (c == c0) return std::string("p0");
        if (c <= c0 + n) return "r=" + format::significant(r[static_cast<std::size_t>(c - c0 - 1)]);
        return o.output_name + " dead zone at " + format::significant(dz[static_cast<std::size_t>(c - c0 - 1 - n)]);
    };

    // Conditioning of the regressors scaled to unit RMS (unique weights).
    Eigen::VectorXd scale = rphi.colwise().norm().transpose() / sqrt_rows;
    for (int j = 0; j < k; ++j)
        if (!(scale(j) > 0.0)) scale(j) = 1.0;
    const Eigen::MatrixXd rf = rphi * scale.cwiseInverse().asDiagonal();
    Eigen::JacobiSVD<Eigen::MatrixXd> svd(rf, Eigen::ComputeFullV);
    const Eigen::VectorXd sv = svd.singularValues();
    res.regressor_condition = sv(k - 1) > 0.0 ? sv(0) / sv(k - 1) : std::numeric_limits<double>::infinity();
    if (!(res.regressor_condition <= 1e10)) {
        const Eigen::VectorXd v = svd.matrixV().col(k - 1);
        const double vmax = v.cwiseAbs().maxCoeff();
        std::string dep;
        for (int c = 0; c < k; ++c)
            if (std::fabs(v(c)) >= 0.1 * vmax) dep += (dep.empty() ? "" : ", ") + column_name(c);
        throw std::invalid_argument(o.input_name + ": play regressors are linearly dependent (condition number " +
                                    format::significant(res.regressor_condition) +
                                    " > 1e10): the input's reversals do not separate the operators " + dep +
                                    "; use fewer operators or an input with more distinct turning points");
    }

    Eigen::VectorXd x(k);  // [c,] p0 .. pn, q1 .. qN
    if (!o.monotone && nz == 0) {
        const Eigen::VectorXd pn = rf.triangularView<Eigen::Upper>().solve(qty);
        x = pn.cwiseQuotient(scale);
    } else {
        // x = T s + t0 with s = [c,] (P0 .. Pn | p0 .. pn), G1 .. GN: the
        // slopes where bounded (P_j >= min_slope, G_i >= min_output_slope).
        Eigen::MatrixXd t = Eigen::MatrixXd::Identity(k, k);
        Eigen::VectorXd t0 = Eigen::VectorXd::Zero(k), lb = Eigen::VectorXd::Zero(k);
        std::vector<bool> bounded(static_cast<std::size_t>(k), false);
        if (o.monotone) {
            double m = o.min_slope;
            if (m < 0.0) m = 1e-3 * (*ymax - *ymin) / (*umax - *umin);
            if (!std::isfinite(m)) throw std::invalid_argument("min_slope: must be finite");
            if (!(m > 0.0))
                throw std::invalid_argument("min_slope: must be > 0 for an invertible model (or < 0 for automatic), and " +
                                            o.output_name + " must not be constant for the automatic value");
            res.min_slope = m;
            for (int j = 0; j <= n; ++j) {
                if (j > 0) t(c0 + j, c0 + j - 1) = -1.0;
                lb(c0 + j) = m;
                bounded[static_cast<std::size_t>(c0 + j)] = true;
            }
        }
        for (int i = 0; i < nz; ++i) {
            const int c = c0 + 1 + n + i;
            if (i > 0) t(c, c - 1) = -1.0;
            lb(c) = o.min_output_slope;
            bounded[static_cast<std::size_t>(c)] = true;
        }
        if (nz > 0) t0(c0 + 1 + n) = -1.0;  // q1 = G1 - 1
        const Eigen::MatrixXd mt = rphi * t;
        for (int j = 0; j < k; ++j)
            if (bounded[static_cast<std::size_t>(j)] && !(mt.col(j).norm() > 0.0))
                throw std::invalid_argument(o.input_name + ": slope regressor of " + column_name(j) +
                                            " is zero: neighbouring operators are indistinguishable on this input");
        const Eigen::VectorXd b = qty - rphi * t0 - mt * lb;
        int active = 0;
        const Eigen::VectorXd sp = bounded_lsq(mt, b, bounded, active);
        res.active_constraints = active;
        x = t * (lb + sp) + t0;
    }
    res.offset = c0 ? x(0) : 0.0;
    const Eigen::VectorXd p = x.segment(c0, n + 1);
    res.weights.assign(p.data(), p.data() + n + 1);
    double slope = 0.0;
    for (int j = 0; j <= n; ++j) {
        slope += p(j);
        res.slopes.push_back(slope);
    }
    if (nz > 0) {
        res.output_inverse.thresholds = dz;
        for (int i = 0; i < nz; ++i) res.output_inverse.weights.push_back(x(c0 + 1 + n + i));
        res.output_map = inverse(res.output_inverse);  // slopes >= min_output_slope > 0
    }
    double z_descended = res.offset;
    for (int j = 1; j <= n; ++j) z_descended += p(j) * r[static_cast<std::size_t>(j - 1)];
    res.offset_after_descent = nz > 0 ? res.output_map.apply(z_descended) : z_descended;

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
    for (int j = 0; j <= n && !st.ok(); ++j)
        if (!(res.slopes[static_cast<std::size_t>(j)] > 0.0)) {
            res.invertibility += "; the fitted loading curve's slope is " + format::significant(res.slopes[static_cast<std::size_t>(j)]) +
                                 (j == 0 ? std::string(" from the start")
                                         : " beyond input excursions of " + format::significant(r[static_cast<std::size_t>(j - 1)])) +
                                 ", so the model's output falls while the input rises and some outputs have no "
                                 "input; refit with the monotone constraint (every slope >= min_slope)";
            break;
        }

    // Errors of the float model as the core evaluates it (S and the offset in double).
    PiOperator<float> op;
    op.configure(mdl);
    FitErrors fit, val;
    double fy = 0.0, fy2 = 0.0, vy = 0.0, vy2 = 0.0;
    for (int s = 0; s < all; ++s) {
        if (o.progress && (s & 0xFFFFF) == 0xFFFFF)
            o.progress("model errors: " + std::to_string((s + 1) >> 20) + " Mi of " + std::to_string(all >> 20) +
                       " Mi rows");
        const double z = res.offset + op.apply(static_cast<float>(u[static_cast<std::size_t>(s)]));
        const double ym = nz > 0 ? res.output_map.apply(z) : z;
        const double yk = y[static_cast<std::size_t>(s)];
        if (s < first) continue;
        if (s < vf) accumulate(fit, fy, fy2, yk - ym, yk);
        else accumulate(val, vy, vy2, yk - ym, yk);
    }
    finish(fit, fy, fy2);
    finish(val, vy, vy2);
    res.rms_error = fit.rms_error;
    res.max_error = fit.max_error;
    res.nrmse_percent = fit.nrmse_percent;
    res.validation = val;
    res.judged_nrmse_percent = val.samples > 0 ? val.nrmse_percent : fit.nrmse_percent;
    res.poor_fit = !(res.judged_nrmse_percent <= o.max_nrmse_percent);
    return res;
}

std::vector<double> PiFitResult::simulate(std::span<const double> u) const {
    std::vector<double> w(thresholds.size(), 0.0), out(u.size());
    for (std::size_t s = 0; s < u.size(); ++s) {
        double z = offset + weights[0] * u[s];
        for (std::size_t j = 0; j < w.size(); ++j) {
            w[j] = std::max(u[s] - thresholds[j], std::min(u[s] + thresholds[j], w[j]));
            z += weights[j + 1] * w[j];
        }
        out[s] = output_map.thresholds.empty() ? z : output_map.apply(z);
    }
    return out;
}

std::vector<double> PiFitResult::invert(std::span<const double> y_desired) const {
    PiModel inv;
    if (const Status st = invert_pi(model, inv); !st.ok())
        throw std::invalid_argument("model not invertible: " + describe(st));
    PiOperator<float> op;
    op.configure(inv);
    std::vector<double> u(y_desired.size());
    for (std::size_t s = 0; s < y_desired.size(); ++s) {
        const double z = output_inverse.thresholds.empty() ? y_desired[s] : output_inverse.apply(y_desired[s]);
        u[s] = op.apply(static_cast<float>(z - offset));
    }
    return u;
}

PiModel PiFitResult::compensator() const {
    PiModel c;
    if (const Status st = invert_pi(model, c); !st.ok())
        throw std::invalid_argument("model not invertible: " + describe(st));
    c.input_offset = static_cast<float>(-offset);
    set_input_map(output_inverse, c);
    if (const Status st = validate(c); !st.ok()) throw std::invalid_argument("compensator: " + describe(st));
    return c;
}

}  // namespace piezoloop::design
