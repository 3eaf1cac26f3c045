#include "ident/dahl_fit.hpp"

#include <algorithm>
#include <cmath>
#include <functional>
#include <limits>
#include <optional>
#include <sstream>
#include <stdexcept>

#include <Eigen/Dense>
#include <unsupported/Eigen/NonLinearOptimization>
#include <unsupported/Eigen/NumericalDiff>

#include "ident/csv_data.hpp"
#include "lti/decompositions.hpp"

namespace piezoloop::design {
namespace {

// See fit_dahl's refusal rules in the header.
constexpr double kMaxRelativeStdError = 0.5;

struct Z {
    double z1 = 0.0, z2 = 0.0;
};

// Exact solution across a path increment dx (direction s = sgn dx):
// z_eq + expm(A_H(s) dx) (z - z_eq), z_eq = (gamma_a/alpha2, 0).
// N = A_H(s) dx = [[0, dx], [-alpha2 dx, -alpha1 |dx|]] has eigenvalues
// tau +- delta, tau = -alpha1 |dx|/2, delta^2 = dx^2 (alpha1^2/4 - alpha2), and
// expm(N) = f0 I + f1 (N - tau I) with f0 = e^tau cosh(delta),
// f1 = e^tau sinh(delta)/delta (cos/sin for imaginary delta). Both
// exponentials are <= 1 (|delta| <= |tau|), so nothing overflows.
Z advance(const DahlParamsD& p, Z z, double dx) {
    if (dx == 0.0) return z;
    const double d = std::fabs(dx);
    const double tau = -0.5 * p.alpha1 * d;
    const double q = 0.25 * p.alpha1 * p.alpha1 - p.alpha2;
    const double delta = d * std::sqrt(std::fabs(q));
    double f0, f1;
    if (delta < 1e-4) {
        // Series in delta^2 (sign of q): error < delta^6/5040.
        const double dd = q >= 0.0 ? delta * delta : -delta * delta;
        const double et = std::exp(tau);
        f0 = et * (1.0 + dd / 2.0 + dd * dd / 24.0);
        f1 = et * (1.0 + dd / 6.0 + dd * dd / 120.0);
    } else if (q >= 0.0) {
        const double ep = std::exp(tau + delta), em = std::exp(tau - delta);
        f0 = 0.5 * (ep + em);
        f1 = (ep - em) / (2.0 * delta);
    } else {
        const double et = std::exp(tau);
        f0 = et * std::cos(delta);
        f1 = et * std::sin(delta) / delta;
    }
    const double zeq = p.gamma_a / p.alpha2;
    const double e1 = z.z1 - zeq, e2 = z.z2;
    const double n11 = -tau, n12 = dx, n21 = -p.alpha2 * dx, n22 = -p.alpha1 * d - tau;
    return {zeq + (f0 + f1 * n11) * e1 + f1 * n12 * e2, f1 * n21 * e1 + (f0 + f1 * n22) * e2};
}

double output(const DahlParamsD& p, Z z, int s) { return p.beta2 * z.z1 + (s < 0 ? -p.beta1 : p.beta1) * z.z2; }

// dH/dx moving in direction s: C_H(s) (A_H(s) z + B_H).
double slope(const DahlParamsD& p, Z z, int s) {
    const double dz1 = z.z2;
    const double dz2 = -p.alpha2 * z.z1 - (s < 0 ? -p.alpha1 : p.alpha1) * z.z2 + p.gamma_a;
    return p.beta2 * dz1 + (s < 0 ? -p.beta1 : p.beta1) * dz2;
}

// The plant, one sample at a time (DahlActuator's algorithm in double).
struct Plant {
    DahlParamsD p;
    Z z;
    double x = 0.0;
    int s = 1;

    void reset(double v0) {
        z = {};
        s = 1;
        x = p.ga * v0;
    }
    double energy() const {
        const double e1 = z.z1 - p.gamma_a / p.alpha2;
        return p.alpha2 * e1 * e1 + z.z2 * z.z2;
    }
    double step(double v) {
        const double target = p.ga * v;
        double h0 = output(p, z, s);
        double res = target - (x + h0);
        const double k = std::sqrt(p.beta2 * p.beta2 / p.alpha2 + p.beta1 * p.beta1);
        const double spread = k * std::sqrt(energy());
        const double heq = p.beta2 * p.gamma_a / p.alpha2;
        const double scale = std::fabs(target) + std::fabs(x) + std::fabs(heq) + spread;
        const double tol = 8.0 * std::numeric_limits<double>::epsilon() * scale + 1e-300;
        if (!(std::fabs(res) > tol)) return x;
        const int sn = res > 0.0 ? 1 : -1;
        if (sn != s) {
            h0 = output(p, z, sn);
            res = target - (x + h0);
            if (!(res * sn > tol)) return x;  // inside the beta1 jump: stick
        }
        const double need = std::fabs(res);
        double lo = 0.0, hi = (need + 2.0 * spread) * (1.0 + 1e-9) + tol;
        const double den0 = 1.0 + slope(p, z, sn);
        double d = den0 > 1e-12 ? need / den0 : 0.5 * hi;
        double best = 0.0;
        Z zbest = z;
        for (int it = 0; it < 200; ++it) {
            if (!(d > lo && d < hi)) d = lo + 0.5 * (hi - lo);
            if (!(d > lo && d < hi)) break;
            const Z zt = advance(p, z, sn * d);
            const double phi = d + sn * (output(p, zt, sn) - h0) - need;
            if (std::fabs(phi) <= tol) {
                best = d;
                zbest = zt;
                break;
            }
            if (phi < 0.0) {
                lo = d;
            } else {
                hi = d;
            }
            best = lo;
            zbest = lo == d ? zt : zbest;
            const double den = 1.0 + slope(p, zt, sn);
            d = den > 1e-12 ? d - phi / den : lo + 0.5 * (hi - lo);
        }
        if (best > 0.0) {
            x += sn * best;
            z = zbest;
            s = sn;
        }
        return x;
    }
};

bool usable(const DahlParamsD& p) {
    const double vals[] = {p.alpha1, p.alpha2, p.beta1, p.beta2, p.gamma_a, p.ga};
    for (double v : vals)
        if (!std::isfinite(v)) return false;
    return p.alpha1 >= 0.0 && p.alpha2 > 0.0 && p.ga > 0.0 && p.gamma_a != 0.0;
}

// Scaled unknowns q = (log alpha1, log alpha2, beta1/sb1, beta2/sb2, log ga).
struct Scaling {
    double gamma_a, sb1, sb2;
    DahlParamsD params(const Eigen::VectorXd& q) const {
        return {std::exp(q(0)), std::exp(q(1)), q(2) * sb1, q(3) * sb2, gamma_a, std::exp(q(4))};
    }
    Eigen::VectorXd unknowns(const DahlParamsD& p) const {
        Eigen::VectorXd q(5);
        q << std::log(std::max(p.alpha1, 1e-300)), std::log(p.alpha2), p.beta1 / sb1, p.beta2 / sb2,
            std::log(p.ga);
        return q;
    }
};

// What one simulation of the fit runs: the samples [0, end) of the record,
// residuals on [first, end); with an estimated start, from the virgin
// state at the unknown v0 = q(5) * v_scale moved straight to v[first].
struct FitWindow {
    std::size_t first = 0, end = 0;
    bool estimated = false;
    double v_scale = 1.0;
};

std::vector<double> simulate_window(const DahlParamsD& p, std::span<const double> v, const FitWindow& w,
                                    const Eigen::VectorXd& q) {
    if (w.estimated) return simulate_dahl_plant_from(p, q(5) * w.v_scale, v.first(w.end), w.first);
    if (w.first == 0 && w.end == v.size()) return simulate_dahl_plant(p, v);
    const std::vector<double> all = simulate_dahl_plant(p, v.first(w.end));
    return {all.begin() + static_cast<std::ptrdiff_t>(w.first), all.end()};
}

struct OutputError {
    typedef double Scalar;
    typedef Eigen::VectorXd InputType;
    typedef Eigen::VectorXd ValueType;
    typedef Eigen::MatrixXd JacobianType;
    enum { InputsAtCompileTime = Eigen::Dynamic, ValuesAtCompileTime = Eigen::Dynamic };

    std::span<const double> v, x;
    Scaling sc;
    double penalty = 0.0;  // residual used when the model cannot be simulated
    int* count = nullptr;
    bool project_offset = false;  // residuals minus their mean (the best offset removed)
    std::function<void()> on_simulation;  // progress
    FitWindow window{};

    int inputs() const { return window.estimated ? 6 : 5; }
    int values() const { return static_cast<int>(window.end - window.first); }
    int operator()(const Eigen::VectorXd& q, Eigen::VectorXd& f) const {
        if (count) ++*count;
        if (on_simulation) on_simulation();
        const DahlParamsD p = sc.params(q);
        f.resize(values());
        if (!usable(p) || (window.estimated && !std::isfinite(q(5)))) {
            f.setConstant(penalty);
            return 0;
        }
        const std::vector<double> xm = simulate_window(p, v, window, q);
        for (int k = 0; k < values(); ++k) {
            const double e = xm[static_cast<std::size_t>(k)] - x[window.first + static_cast<std::size_t>(k)];
            f(k) = std::isfinite(e) ? e : penalty;
        }
        if (project_offset) f.array() -= f.mean();
        return 0;
    }
};

double rms(const Eigen::VectorXd& f) { return std::sqrt(f.squaredNorm() / static_cast<double>(f.size())); }

const char* status_text(Eigen::LevenbergMarquardtSpace::Status s) {
    using namespace Eigen::LevenbergMarquardtSpace;
    switch (s) {
        case RelativeReductionTooSmall: return "relative reduction of the sum of squares below ftol";
        case RelativeErrorTooSmall: return "relative change of the parameters below xtol";
        case RelativeErrorAndReductionTooSmall: return "sum of squares and parameters converged";
        case CosinusTooSmall: return "residual orthogonal to the Jacobian columns";
        case TooManyFunctionEvaluation: return "evaluation limit reached";
        case FtolTooSmall: return "no further reduction possible (ftol)";
        case XtolTooSmall: return "no further improvement possible (xtol)";
        case GtolTooSmall: return "gradient at machine precision";
        default: return "improper input";
    }
}

struct DahlCandidate {
    DahlParamsD p;
    double cost;
    double v0 = 0.0;  // estimated start: the virgin voltage
};

// Equation-error starting points (see header), on the samples [first, end).
// With an estimated start the integrator starts from the virgin state at a
// measured displacement x_v moved straight to x[first], for x_v at the
// fitted samples' lowest, highest and first reading; v0 = (x_v - c) / ga.
std::vector<DahlCandidate> grid_starts(std::span<const double> v_all, std::span<const double> x_all, double gamma_a,
                                   bool offset, const FitWindow& w) {
    const std::span<const double> v = v_all.subspan(w.first, w.end - w.first);
    const std::span<const double> x = x_all.subspan(w.first, w.end - w.first);
    const std::size_t n = v.size();
    // Measured x made monotone between reversals of v.
    std::vector<double> xd(n);
    xd[0] = x[0];
    int dir = 1;
    for (std::size_t k = 1; k < n; ++k) {
        if (v[k] > v[k - 1]) dir = 1;
        if (v[k] < v[k - 1]) dir = -1;
        xd[k] = dir > 0 ? std::max(xd[k - 1], x[k]) : std::min(xd[k - 1], x[k]);
    }
    const auto [xmin, xmax] = std::minmax_element(x.begin(), x.end());
    const double length = *xmax - *xmin;
    std::vector<double> virgin_x{x[0]};
    if (w.estimated) virgin_x = {*xmin, *xmax, x[0]};
    std::vector<DahlCandidate> out;
    for (const double xv : virgin_x) {
        for (double wn : {0.25, 0.5, 1.0, 2.0, 4.0, 8.0}) {
            for (double zeta : {0.1, 0.3, 1.0, 2.0, 4.0}) {
                DahlParamsD p{zeta * wn / length, (wn / length) * (wn / length), 0.0, 0.0, 1.0, 1.0};
                Eigen::MatrixXd a(static_cast<int>(n), offset ? 4 : 3);
                Eigen::VectorXd b(static_cast<int>(n));
                Z z;
                int s = x[0] < xv ? -1 : 1;
                if (w.estimated) z = advance(p, z, x[0] - xv);
                for (std::size_t k = 0; k < n; ++k) {
                    if (k > 0) {
                        const double dx = xd[k] - xd[k - 1];
                        if (dx != 0.0) {
                            z = advance(p, z, dx);
                            s = dx < 0.0 ? -1 : 1;
                        }
                    }
                    const int r = static_cast<int>(k);
                    a(r, 0) = v[k];
                    a(r, 1) = -s * z.z2;
                    a(r, 2) = -z.z1;
                    if (offset) a(r, 3) = 1.0;
                    b(r) = x[k];
                }
                const Eigen::VectorXd sol = a.colPivHouseholderQr().solve(b);
                if (!sol.allFinite() || !(sol(0) > 0.0)) continue;
                p.ga = sol(0);
                p.beta1 = sol(1) / gamma_a;  // fitted beta*gamma_a with gamma_a = 1 in z
                p.beta2 = sol(2) / gamma_a;
                p.gamma_a = gamma_a;
                const double v0 = (xv - (offset ? sol(3) : 0.0)) / p.ga;
                out.push_back({p, (a * sol - b).squaredNorm(), v0});
            }
        }
    }
    std::sort(out.begin(), out.end(), [](const DahlCandidate& l, const DahlCandidate& r) { return l.cost < r.cost; });
    return out;
}

// The input's first turning point: where it has moved back from its extreme
// so far by more than 1 % of its span (the extreme's first sample).
std::optional<std::size_t> first_turning_point(std::span<const double> v, std::size_t end) {
    const auto [lo, hi] = std::minmax_element(v.begin(), v.begin() + static_cast<std::ptrdiff_t>(end));
    const double back = 0.01 * (*hi - *lo);
    std::size_t imax = 0, imin = 0;
    for (std::size_t k = 1; k < end; ++k) {
        if (v[k] > v[imax]) imax = k;
        if (v[k] < v[imin]) imin = k;
        if (v[imax] - v[k] > back && imax > 0) return imax;
        if (v[k] - v[imin] > back && imin > 0) return imin;
    }
    return std::nullopt;
}

}  // namespace

std::vector<double> simulate_dahl_plant(const DahlParamsD& p, std::span<const double> v) {
    std::vector<double> x(v.size());
    if (v.empty()) return x;
    Plant plant{p, {}, 0.0, 1};
    plant.reset(v[0]);
    for (std::size_t k = 0; k < v.size(); ++k) x[k] = plant.step(v[k]);
    return x;
}

std::vector<double> simulate_dahl_plant_from(const DahlParamsD& p, double v0, std::span<const double> v,
                                             std::size_t first) {
    std::vector<double> x;
    if (first >= v.size()) return x;
    x.reserve(v.size() - first);
    Plant plant{p, {}, 0.0, 1};
    plant.reset(v0);
    for (std::size_t k = first; k < v.size(); ++k) x.push_back(plant.step(v[k]));
    return x;
}

DahlFitResult fit_dahl(std::span<const double> v, std::span<const double> x, const DahlFitOptions& o) {
    if (v.size() != x.size())
        throw std::invalid_argument(o.output_name + ": has " + std::to_string(x.size()) + " samples but " +
                                    o.input_name + " has " + std::to_string(v.size()));
    require_finite(v, o.input_name);
    require_finite(x, o.output_name);
    if (!std::isfinite(o.gamma_a) || o.gamma_a == 0.0)
        throw std::invalid_argument("gamma_a: must be finite and non-zero (it is held, see dahl_fit.hpp)");
    if (o.max_evaluations < 10) throw std::invalid_argument("max_evaluations: must be >= 10");
    if (!(o.holdout >= 0.0 && o.holdout <= 0.9)) throw std::invalid_argument("holdout: must be in [0, 0.9]");
    if (v.size() < 50)
        throw std::invalid_argument(o.input_name + ": too short: " + std::to_string(v.size()) +
                                    " samples; the Dahl fit needs at least 50");
    const auto [vmin, vmax] = std::minmax_element(v.begin(), v.end());
    if (!(*vmax > *vmin)) throw std::invalid_argument(o.input_name + ": no excitation: the voltage is constant");
    const auto [xmin, xmax] = std::minmax_element(x.begin(), x.end());
    if (!(*xmax > *xmin))
        throw std::invalid_argument(o.output_name + ": the displacement is constant: nothing to identify");

    // The fitted samples [first, end) and the held-out ones [end, n).
    const std::size_t n = v.size();
    const std::size_t held = static_cast<std::size_t>(std::floor(o.holdout * static_cast<double>(n)));
    FitWindow win;
    win.end = n - held;
    win.estimated = o.start_state == DahlStartState::kEstimated;
    win.v_scale = *vmax - *vmin;
    if (o.first_fitted == DahlFitOptions::kAutoFirstFitted) {
        const std::optional<std::size_t> turn = first_turning_point(v, win.end);
        if (!turn)
            throw std::invalid_argument(o.input_name + ": never turns back by more than 1 % of its span" +
                                        (held ? " before the held-out samples" : "") +
                                        ", so the automatic first fitted sample (the first turning point) does not "
                                        "exist; give the first fitted sample (0: from the record's start)");
        win.first = *turn;
    } else {
        win.first = o.first_fitted;
        if (win.first >= win.end)
            throw std::invalid_argument("first_fitted: " + std::to_string(win.first) + " is not below the " +
                                        std::to_string(win.end) + (held ? " samples before the held-out part" : " samples"));
    }
    if (win.end - win.first < 50)
        throw std::invalid_argument(o.input_name + ": too short: " + std::to_string(win.end - win.first) +
                                    " fitted samples; the Dahl fit needs at least 50");
    const std::span<const double> xf = x.subspan(win.first, win.end - win.first);
    const auto [xfmin, xfmax] = std::minmax_element(xf.begin(), xf.end());
    if (!(*xfmax > *xfmin))
        throw std::invalid_argument(o.output_name + ": the displacement is constant over the fitted samples");
    const int nq = win.estimated ? 6 : 5;

    std::vector<DahlCandidate> starts;
    if (o.start) {
        DahlParamsD s = *o.start;
        s.gamma_a = o.gamma_a;
        if (!usable(s))
            throw std::invalid_argument("start: needs alpha1 >= 0, alpha2 > 0, ga > 0, all finite");
        starts.push_back({s, 0.0, v[win.first]});
    } else {
        const std::vector<DahlCandidate> c = grid_starts(v, x, o.gamma_a, o.fit_offset, win);
        for (std::size_t i = 0; i < c.size() && i < 3; ++i) starts.push_back(c[i]);
        if (starts.empty())
            throw std::invalid_argument(o.output_name +
                                        ": no starting point: the equation-error fit gives no positive ga");
    }

    double mean = 0.0;
    for (double xv : xf) mean += xv;
    mean /= static_cast<double>(xf.size());
    double dev2 = 0.0;
    for (double xv : xf) dev2 += (xv - mean) * (xv - mean);
    const double xrms = std::sqrt(dev2 / static_cast<double>(xf.size()));

    DahlFitResult best;
    double best_cost = std::numeric_limits<double>::infinity();
    Eigen::VectorXd best_q;
    Scaling best_sc{};
    int evaluations = 0;
    for (const DahlCandidate& c0 : starts) {
        DahlParamsD s = c0.p;
        if (!(s.alpha1 > 0.0)) s.alpha1 = 1e-3 * std::sqrt(s.alpha2);  // log needs > 0
        Scaling sc{o.gamma_a, 0.0, std::fabs(s.beta2)};
        if (!(sc.sb2 > 0.0)) sc.sb2 = s.alpha2 * (*xfmax - *xfmin) / std::fabs(o.gamma_a);
        sc.sb1 = std::fabs(s.beta1) > 0.0 ? std::fabs(s.beta1) : sc.sb2 / std::sqrt(s.alpha2);
        OutputError fn{v, x, sc, 1e3 * (xrms + 1.0), &evaluations, o.fit_offset, {}, win};
        if (o.progress) {
            const std::string run = "LM run " + std::to_string(best.starts + 1) + " of " + std::to_string(starts.size());
            fn.on_simulation = [&o, &evaluations, run] {
                o.progress(run + ", " + std::to_string(evaluations) + " model simulations");
            };
        }
        Eigen::NumericalDiff<OutputError> nd(fn);
        Eigen::LevenbergMarquardt<Eigen::NumericalDiff<OutputError>> lm(nd);
        lm.parameters.maxfev = std::max<Eigen::Index>(10, o.max_evaluations / 6);
        lm.parameters.xtol = 1e-12;
        lm.parameters.ftol = 1e-14;
        Eigen::VectorXd q(nq);
        q.head(5) = sc.unknowns(s);
        if (win.estimated) q(5) = c0.v0 / win.v_scale;
        const auto status = lm.minimize(q);
        Eigen::VectorXd f;
        fn(q, f);
        const double cost = f.squaredNorm();
        ++best.starts;
        if (cost < best_cost && usable(sc.params(q))) {
            best_cost = cost;
            best_q = q;
            best_sc = sc;
            best.termination = status_text(status);
        }
    }
    if (!std::isfinite(best_cost))
        throw std::invalid_argument(o.output_name + ": the fit did not reach a usable parameter set");

    const DahlParamsD p = best_sc.params(best_q);
    best.params = p;
    best.params_float = p.to_float();
    best.beta1_gamma_a = p.beta1 * p.gamma_a;
    best.beta2_gamma_a = p.beta2 * p.gamma_a;
    best.first_fitted = win.first;
    best.validated_from = win.end;
    best.fitted_samples = win.end - win.first;

    // Jacobian in the parameters' own units, by central differences.
    OutputError fn{v, x, best_sc, 1e3 * (xrms + 1.0), &evaluations, o.fit_offset, {}, win};
    Eigen::VectorXd f0;
    fn(best_q, f0);
    const int m = static_cast<int>(f0.size());
    Eigen::MatrixXd jq(m, nq);
    for (int j = 0; j < nq; ++j) {
        const double h = 1e-6 * std::max(1.0, std::fabs(best_q(j)));
        Eigen::VectorXd qp = best_q, qm = best_q, fp, fm;
        qp(j) += h;
        qm(j) -= h;
        fn(qp, fp);
        fn(qm, fm);
        jq.col(j) = (fp - fm) / (2.0 * h);
    }
    // dq/dparam: log -> 1/param, scaled -> 1/scale.
    const double dqdp[6] = {1.0 / p.alpha1, 1.0 / p.alpha2, 1.0 / best_sc.sb1, 1.0 / best_sc.sb2, 1.0 / p.ga,
                            1.0 / win.v_scale};
    Eigen::MatrixXd jp = jq;
    for (int j = 0; j < nq; ++j) jp.col(j) *= dqdp[j];
    const char* names[6] = {"alpha1", "alpha2", "beta1", "beta2", "ga", "the virgin start's voltage"};
    // An estimated start the fitted samples have forgotten (alpha1 large:
    // the model's transient ends before the first fitted sample) leaves the
    // output independent of v0: it is then reported without a standard
    // error and kept out of the identifiability checks.
    int nj = nq;
    if (win.estimated) {
        // Moving v0 over the whole input span changes the output by less
        // than 1e-6 of its spread (rms over the fitted samples).
        if (!(jp.col(5).norm() * win.v_scale > 1e-6 * xrms * std::sqrt(static_cast<double>(m)))) nj = 5;
    }
    const Eigen::MatrixXd jpu = jp.leftCols(nj);
    Eigen::VectorXd norms = jpu.colwise().norm().transpose();
    for (int j = 0; j < nj; ++j)
        if (!(norms(j) > 0.0))
            throw std::invalid_argument(std::string(names[j]) + ": not identifiable from these data: the model output does not depend on it");
    Eigen::MatrixXd jn = jpu * norms.cwiseInverse().asDiagonal();
    Eigen::JacobiSVD<Eigen::MatrixXd> svd(jn, Eigen::ComputeThinV);
    const Eigen::VectorXd sv = svd.singularValues();
    best.jacobian_condition = sv(nj - 1) > 0.0 ? sv(0) / sv(nj - 1) : std::numeric_limits<double>::infinity();
    if (!(best.jacobian_condition <= 1e8)) {
        const Eigen::VectorXd nv = svd.matrixV().col(nj - 1);
        const double nmax = nv.cwiseAbs().maxCoeff();
        std::string dep;
        for (int j = 0; j < nj; ++j)
            if (std::fabs(nv(j)) >= 0.1 * nmax) dep += (dep.empty() ? "" : ", ") + std::string(names[j]);
        std::ostringstream msg;
        msg << o.input_name << ": the data cannot identify " << dep
            << " separately (Jacobian condition number " << best.jacobian_condition
            << " > 1e8): use loops that travel further than the hysteresis transient, with reversals";
        throw std::invalid_argument(msg.str());
    }
    const double r = rms(f0);
    // Covariance rms^2 (J^T J)^-1 from the SVD of the normalised Jacobian.
    const Eigen::MatrixXd vs = svd.matrixV() * sv.cwiseInverse().asDiagonal();
    const Eigen::MatrixXd cov_n = vs * vs.transpose();
    for (int j = 0; j < 5; ++j) best.std_errors.push_back(r * std::sqrt(cov_n(j, j)) / norms(j));
    if (win.estimated) {
        best.virgin_V = best_q(5) * win.v_scale;
        if (nj == 6) best.virgin_V_std_error = r * std::sqrt(cov_n(5, 5)) / norms(5);
    }
    // A parameter known only to within half its own size is not identified
    // (beta1 is exempt: 0 is a legitimate value, its error is absolute).
    const double value[5] = {p.alpha1, p.alpha2, p.beta1, p.beta2, p.ga};
    std::string loose;
    for (int j : {0, 1, 3, 4})
        if (!(best.std_errors[static_cast<std::size_t>(j)] <= kMaxRelativeStdError * std::fabs(value[j]))) {
            std::ostringstream e;
            e << names[j] << " = " << value[j] << " +- " << best.std_errors[static_cast<std::size_t>(j)];
            loose += (loose.empty() ? "" : ", ") + e.str();
        }
    if (!loose.empty())
        throw std::invalid_argument(
            o.input_name + ": the data cannot identify the Dahl parameters (standard error > 50 % of the value: " + loose +
            "); use loops that travel further than the hysteresis transient, with reversals" +
            (win.estimated ? ""
                           : "; a record that does not start from the model's virgin state (one that starts "
                             "mid-loop) needs its start estimated (start_state estimated, --start-state estimated)"));

    best.rms_error = r;
    best.max_error = f0.cwiseAbs().maxCoeff();
    best.nrmse_percent = xrms > 0.0 ? 100.0 * r / xrms : 0.0;
    // The model over the whole record: the offset (the mean residual over
    // the fitted samples) and the held-out errors.
    FitWindow whole = win;
    whole.end = n;
    const std::vector<double> xm = simulate_window(p, v, whole, best_q);
    if (o.fit_offset) {
        double sum = 0.0;
        for (std::size_t k = win.first; k < win.end; ++k) sum += x[k] - xm[k - win.first];
        best.offset = sum / static_cast<double>(win.end - win.first);
    }
    if (held > 0) {
        double e2 = 0.0, emax = 0.0, sy = 0.0, sy2 = 0.0;
        for (std::size_t k = win.end; k < n; ++k) {
            const double e = x[k] - best.offset - xm[k - win.first];
            e2 += e * e;
            emax = std::max(emax, std::fabs(e));
            sy += x[k];
            sy2 += x[k] * x[k];
        }
        const double nh = static_cast<double>(held);
        const double d2 = std::max(sy2 - sy * sy / nh, 0.0);
        best.validation_samples = held;
        best.validation_rms_error = std::sqrt(e2 / nh);
        best.validation_max_error = emax;
        best.validation_nrmse_percent = d2 > 0.0 ? 100.0 * std::sqrt(e2 / d2) : std::numeric_limits<double>::infinity();
    }
    const double judged = held > 0 ? best.validation_nrmse_percent : best.nrmse_percent;
    best.poor_fit = !(judged <= o.max_nrmse_percent);
    best.evaluations = evaluations;
    return best;
}

}  // namespace piezoloop::design
