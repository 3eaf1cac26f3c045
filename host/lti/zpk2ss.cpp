// Zpk -> Ss (and Tf -> Ss through it): a cascade of scaled real first- and
// second-order blocks with the gain spread evenly over them.
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
namespace {

// Splits C between B and C so that both have comparable size.
void share(Block& b) {
    const double c = b.C.norm();
    if (c > 0.0 && std::isfinite(c)) {
        const double beta = std::ldexp(1.0, std::ilogb(c) / 2);  // power of two, exact
        b.B *= beta;
        b.C /= beta;
    }
}

// One cascade section: poles (one real, one complex pair given by its +imag
// member, or two reals), zeros (at most as many as poles) and a gain.
struct Section {
    std::vector<cplx> poles;  // 1 real, {pair member}, or 2 reals
    bool pole_pair = false;
    std::vector<double> real_zeros;
    bool has_zero_pair = false;
    cplx zero_pair{};
    int order() const { return pole_pair ? 2 : static_cast<int>(poles.size()); }
    int zero_count() const { return static_cast<int>(real_zeros.size()) + (has_zero_pair ? 2 : 0); }
    int free_slots() const { return order() - zero_count(); }
    double distance(cplx z) const {
        double d = std::numeric_limits<double>::infinity();
        for (cplx p : poles) d = std::min({d, std::abs(p - z), std::abs(std::conj(p) - z)});
        return d;
    }
    // Monic numerator prod(s - z) in ascending-size form {b2, b1, b0} for the
    // second-order case, {b1, b0} for the first-order case.
    void numerator(double& b2, double& b1, double& b0) const {
        if (has_zero_pair) {
            b2 = 1.0;
            b1 = -2.0 * zero_pair.real();
            b0 = std::norm(zero_pair);
        } else if (real_zeros.size() == 2) {
            b2 = 1.0;
            b1 = -(real_zeros[0] + real_zeros[1]);
            b0 = real_zeros[0] * real_zeros[1];
        } else if (real_zeros.size() == 1) {
            b2 = 0.0;
            b1 = 1.0;
            b0 = -real_zeros[0];
        } else {
            b2 = 0.0;
            b1 = 0.0;
            b0 = 1.0;
        }
    }
    cplx value(cplx s) const {
        cplx v = 1.0;
        for (double z : real_zeros) v *= s - z;
        if (has_zero_pair) v *= (s - zero_pair) * (s - std::conj(zero_pair));
        for (cplx p : poles) {
            v /= s - p;
            if (pole_pair) v /= s - std::conj(p);
        }
        return v;
    }
    double natural_frequency() const {
        double logsum = 0.0;
        int count = 0;
        auto add = [&](double m) {
            if (m > 0.0) {
                logsum += std::log(m);
                ++count;
            }
        };
        for (cplx p : poles) add(std::abs(p));
        for (double z : real_zeros) add(std::fabs(z));
        if (has_zero_pair) add(std::abs(zero_pair));
        return count > 0 ? std::exp(logsum / count) : 1.0;
    }
};

Block section_block(const Section& sec, double k) {
    Block b;
    double n2, n1, n0;
    sec.numerator(n2, n1, n0);
    if (sec.order() == 1) {
        const double p = sec.poles[0].real();
        // k (n1 s + n0) / (s - p) = k n1 + k (n0 + n1 p) / (s - p)
        b.A = Eigen::MatrixXd::Constant(1, 1, p);
        b.B = Eigen::VectorXd::Ones(1);
        b.C = Eigen::RowVectorXd::Constant(1, k * (n0 + n1 * p));
        b.D = k * n1;
        share(b);
        return b;
    }
    // Second order, den = s^2 + a1 s + a0. Strictly proper remainder of
    // k (n2 s^2 + n1 s + n0) / den:  k ((n1 - n2 a1) s + (n0 - n2 a0)).
    double a1, a0;
    b.A.resize(2, 2);
    b.B = Eigen::Vector2d(1.0, 0.0);
    b.C.resize(2);
    if (sec.pole_pair) {
        const cplx p = sec.poles[0];
        a1 = -2.0 * p.real();
        const double w0 = std::abs(p);
        a0 = w0 * w0;
        const double r1 = k * (n1 - n2 * a1);
        // n0 - n2 a0 with n0 = |z|^2 when both zeros form a pair: factored as
        // (|z| - |p|)(|z| + |p|) so a notch's zeros near its poles keep
        // their small difference.
        double r0;
        if (sec.has_zero_pair)
            r0 = k * (std::abs(sec.zero_pair) - w0) * (std::abs(sec.zero_pair) + w0);
        else
            r0 = k * (n0 - n2 * a0);
        // x1' = -a1 x1 - w0 x2 + u, x2' = w0 x1:  X1 = s U / den, X2 = w0 U / den.
        b.A << -a1, -w0, w0, 0.0;
        b.C << r1, r0 / w0;
    } else {
        const double p1 = sec.poles[0].real(), p2 = sec.poles[1].real();
        a1 = -(p1 + p2);
        a0 = p1 * p2;
        const double r1 = k * (n1 - n2 * a1);
        const double r0 = k * (n0 - n2 * a0);
        const double sigma = a0 != 0.0 ? std::sqrt(std::fabs(a0)) : 1.0;
        // x1' = p1 x1 + u, x2' = sigma x1 + p2 x2:
        // X1 = U / (s - p1), X2 = sigma U / den; r1 s + r0 = c1 (s - p2) + c2 sigma.
        b.A << p1, 0.0, sigma, p2;
        b.C << r1, (r0 + r1 * p2) / sigma;
    }
    b.D = k * n2;
    share(b);
    return b;
}

}  // namespace

Ss zpk2ss(const Zpk& zpk) {
    if (!std::isfinite(zpk.gain)) fail("zpk.gain: must be finite");
    if (!std::isfinite(zpk.ts) || zpk.ts < 0.0) fail("zpk.ts: must be finite and >= 0");
    std::vector<double> zr, pr;
    std::vector<cplx> zc, pc;
    split_conjugates(zpk.zeros, zr, zc, "zpk.zeros");
    split_conjugates(zpk.poles, pr, pc, "zpk.poles");
    if (zpk.zeros.size() > zpk.poles.size())
        fail(cat("zpk: improper model (", std::to_string(zpk.zeros.size()), " zeros, ",
                 std::to_string(zpk.poles.size()), " poles) has no state-space realisation"));

    std::vector<Section> sections;
    for (cplx p : pc) {
        Section s;
        s.poles = {p};
        s.pole_pair = true;
        sections.push_back(s);
    }
    // Complex zero pairs, nearest to a complex pole pair first, each to the
    // nearest free second-order section; if none is free, to a new section
    // made of the two real poles nearest to it.
    std::sort(zc.begin(), zc.end(), [&](cplx a, cplx b) {
        auto nearest = [&](cplx z) {
            double d = std::numeric_limits<double>::infinity();
            for (cplx p : pc) d = std::min(d, std::abs(p - z));
            return d;
        };
        const double da = nearest(a), db = nearest(b);
        return da != db ? da < db : root_less(a, b);
    });
    std::sort(pr.begin(), pr.end());
    for (cplx z : zc) {
        Section* best = nullptr;
        for (Section& s : sections)
            if (s.order() == 2 && s.zero_count() == 0 && (best == nullptr || s.distance(z) < best->distance(z)))
                best = &s;
        if (best == nullptr) {
            Section s;
            for (int k = 0; k < 2; ++k) {
                auto it = std::min_element(pr.begin(), pr.end(), [&](double a, double b) {
                    return std::abs(cplx(a) - z) < std::abs(cplx(b) - z);
                });
                s.poles.emplace_back(*it, 0.0);
                pr.erase(it);
            }
            sections.push_back(s);
            best = &sections.back();
        }
        best->has_zero_pair = true;
        best->zero_pair = z;
    }
    for (double p : pr) {
        Section s;
        s.poles = {cplx(p, 0.0)};
        sections.push_back(s);
    }
    std::sort(zr.begin(), zr.end(), [](double a, double b) { return std::fabs(a) < std::fabs(b); });
    for (double z : zr) {
        Section* best = nullptr;
        for (Section& s : sections)
            if (s.free_slots() > 0 && (best == nullptr || s.distance(z) < best->distance(z))) best = &s;
        best->real_zeros.push_back(z);  // a free slot exists: #zeros <= #poles
    }

    Ss out;
    out.ts = zpk.ts;
    if (sections.empty()) {
        out.A.resize(0, 0);
        out.B.resize(0);
        out.C.resize(0);
        out.D = zpk.gain;
        return out;
    }
    // Each section normalised to magnitude 1 at s = j w0 (w0: geometric mean
    // of its root magnitudes; only a scaling, so the same rule serves
    // discrete models), then the gain spread geometrically over the sections.
    const size_t m = sections.size();
    std::vector<double> g(m);
    double log_total = std::log(std::fabs(zpk.gain));
    for (size_t i = 0; i < m; ++i) {
        const double w = sections[i].natural_frequency();
        const double v = std::abs(sections[i].value(cplx(0.0, w)));
        g[i] = (std::isfinite(v) && v > 0.0) ? v : 1.0;
        log_total += std::log(g[i]);
    }
    const double c = std::exp(log_total / static_cast<double>(m));
    Block total;
    for (size_t i = 0; i < m; ++i) {
        double k = zpk.gain == 0.0 ? (i == 0 ? 0.0 : 1.0 / g[i]) : c / g[i];
        if (i == 0 && zpk.gain < 0.0) k = -k;
        const Block b = section_block(sections[i], k);
        total = i == 0 ? b : cascade(total, b);
    }
    // Correct the rounding of exp/log in the spread gain exactly at the end
    // (ratio of the intended and realised leading gains).
    out.A = total.A;
    out.B = total.B;
    out.C = total.C;
    out.D = total.D;
    if (zpk.gain != 0.0) {
        double realised = 1.0;
        for (size_t i = 0; i < m; ++i) realised *= (c / g[i]);
        const double fix = std::fabs(zpk.gain) / realised;
        out.C *= fix;
        out.D *= fix;
    }
    return out;
}

Ss tf2ss(const Tf& tf) { return zpk2ss(tf2zpk(tf)); }

}  // namespace piezoloop::design
