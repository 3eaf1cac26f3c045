// Tf <-> Zpk and series composition of lti_convert.hpp. The other
// conversions: zpk2ss.cpp, ss2zpk.cpp; polynomials: poly.cpp.
#include "lti/lti_convert.hpp"
#include "lti/lti_convert_detail.hpp"
#include "lti/text.hpp"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <limits>
#include <stdexcept>
#include <string>

#include <Eigen/Eigenvalues>

namespace piezoloop::design {
using namespace convert_detail;

// ---- conversions --------------------------------------------------------------

Zpk tf2zpk(const Tf& tf) {
    if (tf.den.empty()) fail("tf.den: must not be empty");
    if (tf.num.empty()) fail("tf.num: must not be empty");
    for (size_t i = 0; i < tf.den.size(); ++i)
        if (!std::isfinite(tf.den[i])) fail(cat("tf.den[", std::to_string(i), "]: must be finite"));
    for (size_t i = 0; i < tf.num.size(); ++i)
        if (!std::isfinite(tf.num[i])) fail(cat("tf.num[", std::to_string(i), "]: must be finite"));
    if (tf.den[0] == 0.0) fail("tf.den[0]: leading coefficient must be non-zero");
    if (!std::isfinite(tf.ts) || tf.ts < 0.0) fail("tf.ts: must be finite and >= 0");
    Zpk out;
    out.ts = tf.ts;
    out.poles = poly_roots(tf.den);
    const std::vector<double> num = strip_leading_zeros(tf.num);
    if (num.empty()) {
        out.gain = 0.0;
        return out;
    }
    out.zeros = poly_roots(num);
    out.gain = num[0] / tf.den[0];
    return out;
}

Tf zpk2tf(const Zpk& zpk) {
    if (!std::isfinite(zpk.gain)) fail("zpk.gain: must be finite");
    std::vector<double> real;
    std::vector<cplx> upper;
    split_conjugates(zpk.zeros, real, upper, "zpk.zeros");
    split_conjugates(zpk.poles, real, upper, "zpk.poles");
    Tf out;
    out.ts = zpk.ts;
    out.den = poly_from_roots(zpk.poles);
    if (zpk.gain == 0.0) {
        out.num = {0.0};
    } else {
        out.num = poly_from_roots(zpk.zeros);
        for (double& c : out.num) c *= zpk.gain;
    }
    return out;
}

// ---- composition -------------------------------------------------------------

Zpk series(const std::vector<Zpk>& models) {
    if (models.empty()) fail("series: needs at least one model");
    Zpk out;
    out.ts = models[0].ts;
    out.gain = 1.0;
    for (const Zpk& m : models) {
        check_ts(out.ts, m.ts, "series");
        out.zeros.insert(out.zeros.end(), m.zeros.begin(), m.zeros.end());
        out.poles.insert(out.poles.end(), m.poles.begin(), m.poles.end());
        out.gain *= m.gain;
    }
    return out;
}

Zpk series(const Zpk& first, const Zpk& second) { return series(std::vector<Zpk>{first, second}); }

Tf series(const Tf& first, const Tf& second) {
    check_ts(first.ts, second.ts, "series");
    Tf out;
    out.ts = first.ts;
    out.num = poly_mul(first.num, second.num);
    out.den = poly_mul(first.den, second.den);
    return out;
}

Ss series(const Ss& first, const Ss& second) {
    check_ss(first);
    check_ss(second);
    check_ts(first.ts, second.ts, "series");
    const Block b = cascade(Block{first.A, first.B, first.C, first.D}, Block{second.A, second.B, second.C, second.D});
    Ss out;
    out.A = b.A;
    out.B = b.B;
    out.C = b.C;
    out.D = b.D;
    out.ts = first.ts;
    return out;
}

int relative_degree(const Zpk& zpk) { return static_cast<int>(zpk.poles.size()) - static_cast<int>(zpk.zeros.size()); }

}  // namespace piezoloop::design
