#include "ident/dahl_fit.hpp"

#include <algorithm>
#include <cmath>
#include <functional>
#include <limits>
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

    int inputs() const { return 5; }
    int values() const { return static_cast<int>(x.size()); }
    int operator()(const Eigen::VectorXd& q, Eigen::VectorXd& f) const {
        if (count) ++*count;
        if (on_simulation) on_simulation();
        const DahlParamsD p = sc.params(q);
        f.resize(values());
        if (!usable(p)) {
            f.setConstant(penalty);
            return 0;
        }
        const std::vector<double> xm = simulate_dahl_plant(p, v);
        for (int k = 0; k < values(); ++k) {
            const double e = xm[static_cast<std::size_t>(k)] - x[static_cast<std::size_t>(k)];
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

struct Candidate {
    DahlParamsD p;
    double cost;
};

// Equation-error starting points (see header).
std::vector<Candidate> grid_starts(std::span<const double> v, std::span<const double> x, double gamma_a,
                                   bool offset) {
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
    std::vector<Candidate> out;
    for (double w : {0.25, 0.5, 1.0, 2.0, 4.0, 8.0}) {
        for (double zeta : {0.1, 0.3, 1.0, 2.0, 4.0}) {
            DahlParamsD p{zeta * w / length, (w / length) * (w / length), 0.0, 0.0, 1.0, 1.0};
            Eigen::MatrixXd a(static_cast<int>(n), offset ? 4 : 3);
            Eigen::VectorXd b(static_cast<int>(n));
            Z z;
            int s = 1;
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
            out.push_back({p, (a * sol - b).squaredNorm()});
        }
    }
    std::sort(out.begin(), out.end(), [](const Candidate& l, const Candidate& r) { return l.cost < r.cost; });
    return out;
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

DahlFitResult fit_dahl(std::span<const double> v, std::span<const double> x, const DahlFitOptions& o) {
    if (v.size() != x.size())
        throw std::invalid_argument(o.output_name + ": has " + std::to_string(x.size()) + " samples but " +
                                    o.input_name + " has " + std::to_string(v.size()));
    require_finite(v, o.input_name);
    require_finite(x, o.output_name);
    if (!std::isfinite(o.gamma_a) || o.gamma_a == 0.0)
        throw std::invalid_argument("gamma_a: must be finite and non-zero (it is held, see dahl_fit.hpp)");
    if (o.max_evaluations < 10) throw std::invalid_argument("max_evaluations: must be >= 10");
    if (v.size() < 50)
        throw std::invalid_argument(o.input_name + ": too short: " + std::to_string(v.size()) +
                                    " samples; the Dahl fit needs at least 50");
    const auto [vmin, vmax] = std::minmax_element(v.begin(), v.end());
    if (!(*vmax > *vmin)) throw std::invalid_argument(o.input_name + ": no excitation: the voltage is constant");
    const auto [xmin, xmax] = std::minmax_element(x.begin(), x.end());
    if (!(*xmax > *xmin))
        throw std::invalid_argument(o.output_name + ": the displacement is constant: nothing to identify");

    std::vector<DahlParamsD> starts;
    if (o.start) {
        DahlParamsD s = *o.start;
        s.gamma_a = o.gamma_a;
        if (!usable(s))
            throw std::invalid_argument("start: needs alpha1 >= 0, alpha2 > 0, ga > 0, all finite");
        starts.push_back(s);
    } else {
        const std::vector<Candidate> c = grid_starts(v, x, o.gamma_a, o.fit_offset);
        for (std::size_t i = 0; i < c.size() && i < 3; ++i) starts.push_back(c[i].p);
        if (starts.empty())
            throw std::invalid_argument(o.output_name +
                                        ": no starting point: the equation-error fit gives no positive ga");
    }

    double mean = 0.0;
    for (double xv : x) mean += xv;
    mean /= static_cast<double>(x.size());
    double dev2 = 0.0;
    for (double xv : x) dev2 += (xv - mean) * (xv - mean);
    const double xrms = std::sqrt(dev2 / static_cast<double>(x.size()));

    DahlFitResult best;
    double best_cost = std::numeric_limits<double>::infinity();
    Eigen::VectorXd best_q;
    Scaling best_sc{};
    int evaluations = 0;
    for (const DahlParamsD& s0 : starts) {
        DahlParamsD s = s0;
        if (!(s.alpha1 > 0.0)) s.alpha1 = 1e-3 * std::sqrt(s.alpha2);  // log needs > 0
        Scaling sc{o.gamma_a, 0.0, std::fabs(s.beta2)};
        if (!(sc.sb2 > 0.0)) sc.sb2 = s.alpha2 * (*xmax - *xmin) / std::fabs(o.gamma_a);
        sc.sb1 = std::fabs(s.beta1) > 0.0 ? std::fabs(s.beta1) : sc.sb2 / std::sqrt(s.alpha2);
        OutputError fn{v, x, sc, 1e3 * (xrms + 1.0), &evaluations, o.fit_offset, {}};
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
        Eigen::VectorXd q = sc.unknowns(s);
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

    // Jacobian in the parameters' own units, by central differences.
    OutputError fn{v, x, best_sc, 1e3 * (xrms + 1.0), &evaluations, o.fit_offset, {}};
    Eigen::VectorXd f0;
    fn(best_q, f0);
    const int m = static_cast<int>(x.size());
    Eigen::MatrixXd jq(m, 5);
    for (int j = 0; j < 5; ++j) {
        const double h = 1e-6 * std::max(1.0, std::fabs(best_q(j)));
        Eigen::VectorXd qp = best_q, qm = best_q, fp, fm;
        qp(j) += h;
        qm(j) -= h;
        fn(qp, fp);
        fn(qm, fm);
        jq.col(j) = (fp - fm) / (2.0 * h);
    }
    // dq/dparam: log -> 1/param, scaled -> 1/scale.
    const double dqdp[5] = {1.0 / p.alpha1, 1.0 / p.alpha2, 1.0 / best_sc.sb1, 1.0 / best_sc.sb2, 1.0 / p.ga};
    Eigen::MatrixXd jp = jq;
    for (int j = 0; j < 5; ++j) jp.col(j) *= dqdp[j];
    Eigen::VectorXd norms = jp.colwise().norm().transpose();
    const char* names[5] = {"alpha1", "alpha2", "beta1", "beta2", "ga"};
    for (int j = 0; j < 5; ++j)
        if (!(norms(j) > 0.0))
            throw std::invalid_argument(std::string(names[j]) + ": not identifiable from these data: the model output does not depend on it");
    Eigen::MatrixXd jn = jp * norms.cwiseInverse().asDiagonal();
    Eigen::JacobiSVD<Eigen::MatrixXd> svd(jn, Eigen::ComputeThinV);
    const Eigen::VectorXd sv = svd.singularValues();
    best.jacobian_condition = sv(4) > 0.0 ? sv(0) / sv(4) : std::numeric_limits<double>::infinity();
    if (!(best.jacobian_condition <= 1e8)) {
        const Eigen::VectorXd nv = svd.matrixV().col(4);
        const double nmax = nv.cwiseAbs().maxCoeff();
        std::string dep;
        for (int j = 0; j < 5; ++j)
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
        throw std::invalid_argument(o.input_name + ": the data cannot identify the Dahl parameters (standard error > 50 % of the value: " +
                                    loose + "); use loops that travel further than the hysteresis transient, with reversals");

    best.rms_error = r;
    best.max_error = f0.cwiseAbs().maxCoeff();
    best.nrmse_percent = xrms > 0.0 ? 100.0 * r / xrms : 0.0;
    best.poor_fit = !(best.nrmse_percent <= o.max_nrmse_percent);
    if (o.fit_offset) {
        const std::vector<double> xm = simulate_dahl_plant(p, v);
        double sum = 0.0;
        for (std::size_t k = 0; k < x.size(); ++k) sum += x[k] - xm[k];
        best.offset = sum / static_cast<double>(x.size());
    }
    best.evaluations = evaluations;
    return best;
}

}  // namespace piezoloop::design
