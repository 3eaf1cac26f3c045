#include "lti/freqresp.hpp"

#include <algorithm>
#include <cmath>
#include <limits>
#include <numbers>
#include <stdexcept>
#include <string>

#include <Eigen/LU>

#include "lti/lti_convert.hpp"

namespace piezoloop::design {
namespace {

// Horner of a polynomial (descending) at x with |x| <= 1, or of its reversal
// at 1/x; returns p(x) / x^deg in the second case (the caller restores x^deg).
cplx horner_scaled(const std::vector<double>& p, cplx x, bool reversed) {
    cplx v = 0.0;
    if (!reversed) {
        for (double c : p) v = v * x + c;
    } else {
        const cplx y = 1.0 / x;
        for (auto it = p.rbegin(); it != p.rend(); ++it) v = v * y + *it;
    }
    return v;
}

// Product of the factors of zpk at a point given as x = base + offset with
// each factor (x - r) formed as offset + (base - r). For z = e^{jwTs} near
// z = 1 and poles near 1 (|z - p| ~ 1e-5 at 100 kHz) this avoids the
// cancellation of forming z first: e^{jwTs} - 1 is computed directly and
// 1 - p is exact (Sterbenz) for p near 1.
cplx product(const Zpk& zpk, cplx base, cplx offset) {
    // Interleave zeros and poles so that the partial product neither
    // overflows nor underflows for models with many far-apart roots.
    cplx v = zpk.gain;
    const size_t nz = zpk.zeros.size(), np = zpk.poles.size();
    for (size_t i = 0; i < std::max(nz, np); ++i) {
        if (i < nz) v *= offset + (base - zpk.zeros[i]);
        if (i < np) v /= offset + (base - zpk.poles[i]);
    }
    return v;
}

}  // namespace

// e^{j theta} - 1 without cancellation: -2 sin^2(theta/2) + j sin(theta).
cplx expj_minus_one(double theta) {
    const double h = std::sin(0.5 * theta);
    return cplx(-2.0 * h * h, std::sin(theta));
}

cplx evaluate(const Zpk& zpk, cplx x) { return product(zpk, x, 0.0); }

cplx evaluate(const Tf& tf, cplx x) {
    if (tf.den.empty() || tf.num.empty()) throw std::invalid_argument("tf: num and den must not be empty");
    const bool reversed = std::abs(x) > 1.0;
    const cplx n = horner_scaled(tf.num, x, reversed);
    const cplx d = horner_scaled(tf.den, x, reversed);
    cplx v = n / d;
    if (reversed) {
        // p(x) = x^deg * reversed value; restore x^(deg num - deg den).
        const int excess = static_cast<int>(tf.num.size()) - static_cast<int>(tf.den.size());
        v *= std::pow(x, excess);
    }
    return v;
}

cplx evaluate(const Ss& ss, cplx x) {
    const Eigen::Index n = ss.A.rows();
    if (n == 0) return ss.D;
    const Ss b = balance(ss);
    const Eigen::MatrixXcd m = x * Eigen::MatrixXcd::Identity(n, n) - b.A.cast<cplx>();
    const Eigen::VectorXcd v = m.fullPivLu().solve(b.B.cast<cplx>());
    return (b.C.cast<cplx>() * v)(0) + b.D;
}

cplx frequency_point(double w_rad_s, double ts) {
    if (is_discrete(ts)) return std::polar(1.0, w_rad_s * ts);
    return cplx(0.0, w_rad_s);
}

std::vector<cplx> freqresp(const Zpk& zpk, const std::vector<double>& w_rad_s) {
    std::vector<cplx> out;
    out.reserve(w_rad_s.size());
    for (double w : w_rad_s) {
        if (is_discrete(zpk.ts))
            out.push_back(product(zpk, 1.0, expj_minus_one(w * zpk.ts)));
        else
            out.push_back(product(zpk, cplx(0.0, w), 0.0));
    }
    return out;
}

std::vector<cplx> freqresp(const Tf& tf, const std::vector<double>& w_rad_s) {
    std::vector<cplx> out;
    out.reserve(w_rad_s.size());
    for (double w : w_rad_s) out.push_back(evaluate(tf, frequency_point(w, tf.ts)));
    return out;
}

std::vector<cplx> freqresp(const Ss& ss, const std::vector<double>& w_rad_s) {
    const Ss b = balance(ss);
    const Eigen::Index n = b.A.rows();
    std::vector<cplx> out;
    out.reserve(w_rad_s.size());
    const Eigen::MatrixXcd a = b.A.cast<cplx>();
    const Eigen::VectorXcd bb = b.B.cast<cplx>();
    const Eigen::RowVectorXcd c = b.C.cast<cplx>();
    for (double w : w_rad_s) {
        if (n == 0) {
            out.emplace_back(b.D);
            continue;
        }
        // (xI - A), for discrete models as (e^{jwTs} - 1) I + (I - A): see product().
        Eigen::MatrixXcd m;
        if (is_discrete(b.ts))
            m = expj_minus_one(w * b.ts) * Eigen::MatrixXcd::Identity(n, n) + (Eigen::MatrixXcd::Identity(n, n) - a);
        else
            m = cplx(0.0, w) * Eigen::MatrixXcd::Identity(n, n) - a;
        const Eigen::VectorXcd v = m.fullPivLu().solve(bb);
        out.push_back((c * v)(0) + b.D);
    }
    return out;
}

double dc_gain(const Zpk& zpk) {
    const cplx x = is_discrete(zpk.ts) ? cplx(1.0, 0.0) : cplx(0.0, 0.0);
    for (const cplx& p : zpk.poles)
        if (p == x) {
            // A pole at DC: infinite gain with the sign of the rest.
            Zpk rest = zpk;
            rest.poles.clear();
            for (const cplx& q : zpk.poles)
                if (q != x) rest.poles.push_back(q);
            const double v = evaluate(rest, x).real();
            return std::copysign(std::numeric_limits<double>::infinity(), v);
        }
    return evaluate(zpk, x).real();
}

std::vector<double> logspace(double lo, double hi, int n) {
    if (!(lo > 0.0) || !(hi > 0.0) || !std::isfinite(lo) || !std::isfinite(hi))
        throw std::invalid_argument("logspace: ends must be finite and > 0");
    if (n < 2) throw std::invalid_argument("logspace: n must be >= 2");
    std::vector<double> out(static_cast<size_t>(n));
    const double a = std::log10(lo), b = std::log10(hi);
    for (int i = 0; i < n; ++i) out[static_cast<size_t>(i)] = std::pow(10.0, a + (b - a) * i / (n - 1));
    out.front() = lo;
    out.back() = hi;
    return out;
}

std::vector<double> hz_to_rad_s(const std::vector<double>& f_hz) {
    std::vector<double> out;
    out.reserve(f_hz.size());
    for (double f : f_hz) out.push_back(2.0 * std::numbers::pi * f);
    return out;
}

double magnitude_db(cplx h) { return 20.0 * std::log10(std::abs(h)); }

double phase_deg(cplx h) { return std::arg(h) * 180.0 / std::numbers::pi; }

}  // namespace piezoloop::design
