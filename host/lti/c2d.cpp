#include "lti/c2d.hpp"
#include "lti/text.hpp"

#include <cmath>
#include <cstdio>
#include <numbers>
#include <stdexcept>

#include <unsupported/Eigen/MatrixFunctions>

#include "lti/freqresp.hpp"
#include "lti/lti_convert.hpp"

namespace piezoloop::design {
namespace {

void check_continuous(const Zpk& z, double ts) {
    if (is_discrete(z.ts)) throw std::invalid_argument("c2d: the model is already discrete (it has ts)");
    if (!std::isfinite(ts) || !(ts > 0.0)) throw std::invalid_argument("c2d: ts must be finite and > 0");
    if (!std::isfinite(z.gain)) throw std::invalid_argument("c2d: model gain must be finite");
    if (z.zeros.size() > z.poles.size())
        throw std::invalid_argument(cat("c2d: improper model (", std::to_string(z.zeros.size()), " zeros, ",
                                        std::to_string(z.poles.size()), " poles)"));
}

// e^{r ts} for a root; exact conjugates stay exact (cplx exp of the
// conjugate is the conjugate).
cplx exp_root(cplx r, double ts) { return std::exp(r * ts); }

}  // namespace

C2dMethod parse_c2d_method(const std::string& name) {
    if (name == "tustin" || name == "bilinear") return C2dMethod::kTustin;
    if (name == "zoh") return C2dMethod::kZoh;
    if (name == "matched") return C2dMethod::kMatched;
    throw std::invalid_argument(cat("method: '", name, "' is not one of tustin, zoh, matched"));
}

const char* c2d_method_name(C2dMethod m) {
    switch (m) {
        case C2dMethod::kTustin: return "tustin";
        case C2dMethod::kZoh: return "zoh";
        case C2dMethod::kMatched: return "matched";
    }
    return "?";
}

Zpk tustin(const Zpk& c, double ts, double prewarp_rad_s) {
    check_continuous(c, ts);
    if (!std::isfinite(prewarp_rad_s) || prewarp_rad_s < 0.0)
        throw std::invalid_argument("prewarp: must be >= 0 (0: no pre-warping)");
    double k = 2.0 / ts;
    if (prewarp_rad_s > 0.0) {
        const double half = 0.5 * prewarp_rad_s * ts;
        if (!(half < 0.5 * std::numbers::pi))
            throw std::invalid_argument(cat("prewarp: ", fmt(prewarp_rad_s / (2.0 * std::numbers::pi)),
                                            " Hz must be below Nyquist (", fmt(0.5 / ts), " Hz)"));
        k = prewarp_rad_s / std::tan(half);
    }
    Zpk d;
    d.ts = ts;
    cplx num = c.gain, den = 1.0;
    auto map = [&](cplx r, const char* what) {
        if (r == cplx(k, 0.0))
            throw std::invalid_argument(cat("c2d: a ", what, " at s = 2/Ts (", fmt(k), ") maps to infinity"));
        return (k + r) / (k - r);
    };
    for (const cplx& z : c.zeros) {
        d.zeros.push_back(map(z, "zero"));
        num *= k - z;
    }
    for (const cplx& p : c.poles) {
        d.poles.push_back(map(p, "pole"));
        den *= k - p;
    }
    for (size_t i = c.zeros.size(); i < c.poles.size(); ++i) d.zeros.emplace_back(-1.0, 0.0);
    d.gain = (num / den).real();  // real: roots in conjugate pairs
    d.zeros = canonical_roots(d.zeros, "zeros");
    d.poles = canonical_roots(d.poles, "poles");
    return d;
}

Ss zoh(const Ss& c, double ts) {
    if (is_discrete(c.ts)) throw std::invalid_argument("c2d: the model is already discrete (it has ts)");
    if (!std::isfinite(ts) || !(ts > 0.0)) throw std::invalid_argument("c2d: ts must be finite and > 0");
    const Ss b = balance(c);
    const Eigen::Index n = b.A.rows();
    Eigen::MatrixXd m = Eigen::MatrixXd::Zero(n + 1, n + 1);
    m.topLeftCorner(n, n) = b.A * ts;
    m.topRightCorner(n, 1) = b.B * ts;
    const Eigen::MatrixXd e = m.exp();
    Ss d;
    d.A = e.topLeftCorner(n, n);
    d.B = e.topRightCorner(n, 1);
    d.C = b.C;
    d.D = b.D;
    d.ts = ts;
    return d;
}

Zpk zoh(const Zpk& c, double ts) {
    check_continuous(c, ts);
    Zpk d = ss2zpk(zoh(zpk2ss(c), ts));
    // ZOH maps every pole exactly to e^{p ts}; use those (same order of
    // magnitude of error otherwise, but exact conjugates and no eig error).
    d.poles.clear();
    for (const cplx& p : c.poles) d.poles.push_back(exp_root(p, ts));
    d.poles = canonical_roots(d.poles, "poles");
    return d;
}

Zpk matched(const Zpk& c, double ts) {
    check_continuous(c, ts);
    Zpk d;
    d.ts = ts;
    bool root_at_dc = false;
    for (const cplx& z : c.zeros) {
        d.zeros.push_back(exp_root(z, ts));
        root_at_dc = root_at_dc || z == 0.0;
    }
    for (const cplx& p : c.poles) {
        d.poles.push_back(exp_root(p, ts));
        root_at_dc = root_at_dc || p == 0.0;
    }
    for (size_t i = c.zeros.size(); i < c.poles.size(); ++i) d.zeros.emplace_back(-1.0, 0.0);
    d.zeros = canonical_roots(d.zeros, "zeros");
    d.poles = canonical_roots(d.poles, "poles");
    d.gain = 1.0;
    // Gain: match at DC, or (root at s = 0) the magnitude at 1e-3 Nyquist,
    // with the sign that keeps the phase closest.
    const double w = root_at_dc ? 1e-3 * std::numbers::pi / ts : 0.0;
    const cplx hc = evaluate(c, cplx(0.0, w));
    const cplx hd = freqresp(d, {w})[0];
    const cplx ratio = hc / hd;
    d.gain = root_at_dc ? std::copysign(std::abs(ratio), ratio.real()) : ratio.real();
    return d;
}

Zpk c2d(const Zpk& c, double ts, C2dMethod method, double prewarp_rad_s) {
    switch (method) {
        case C2dMethod::kTustin: return tustin(c, ts, prewarp_rad_s);
        case C2dMethod::kZoh: return zoh(c, ts);
        case C2dMethod::kMatched: return matched(c, ts);
    }
    throw std::invalid_argument("c2d: unknown method");
}

}  // namespace piezoloop::design
