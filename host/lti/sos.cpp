#include "lti/sos.hpp"

#include <algorithm>
#include <cmath>
#include <limits>
#include <numbers>
#include <stdexcept>

#include "lti/freqresp.hpp"
#include "lti/lti_convert.hpp"

namespace piezoloop::design {
namespace {

bool is_real(cplx x) { return x.imag() == 0.0; }

// scipy.signal._cplxreal: one member (+imag) of each conjugate pair, sorted
// by real part then |imag|, followed by the real roots sorted by value.
std::vector<cplx> cplxreal(const std::vector<cplx>& roots) {
    std::vector<double> real;
    std::vector<cplx> upper;
    split_conjugates(roots, real, upper, "roots");
    std::stable_sort(upper.begin(), upper.end(), [](cplx a, cplx b) {
        if (a.real() != b.real()) return a.real() < b.real();
        return std::fabs(a.imag()) < std::fabs(b.imag());
    });
    std::stable_sort(real.begin(), real.end());
    std::vector<cplx> out = upper;
    for (double r : real) out.emplace_back(r, 0.0);
    return out;
}

// Index of the root nearest the unit circle (first on ties, as np.argmin).
size_t idx_worst(const std::vector<cplx>& p) {
    size_t best = 0;
    double d = std::numeric_limits<double>::infinity();
    for (size_t i = 0; i < p.size(); ++i) {
        const double di = std::fabs(1.0 - std::abs(p[i]));
        if (di < d) {
            d = di;
            best = i;
        }
    }
    return best;
}

enum class Which { kReal, kComplex, kAny };

// scipy's _nearest_real_complex_idx: the nearest element of `from` to `to`
// of the requested kind (stable order on ties).
size_t nearest_idx(const std::vector<cplx>& from, cplx to, Which which) {
    std::vector<size_t> order(from.size());
    for (size_t i = 0; i < order.size(); ++i) order[i] = i;
    std::stable_sort(order.begin(), order.end(),
                     [&](size_t a, size_t b) { return std::abs(from[a] - to) < std::abs(from[b] - to); });
    for (size_t i : order) {
        if (which == Which::kAny) return i;
        if ((which == Which::kReal) == is_real(from[i])) return i;
    }
    throw std::logic_error("zpk2sos: no zero of the required kind left (pairing bug)");
}

// Real polynomial (descending) of one or two roots, as numpy.poly: a
// conjugate pair gives [1, -2 re, re^2 + im^2].
std::vector<double> small_poly(const std::vector<cplx>& r) {
    if (r.empty()) return {1.0};
    if (r.size() == 1) return {1.0, -r[0].real()};
    const cplx s = r[0] + r[1], p = r[0] * r[1];
    return {1.0, -s.real(), p.real()};
}

SosSection single_section(const std::vector<cplx>& z, const std::vector<cplx>& p) {
    const std::vector<double> b = small_poly(z), a = small_poly(p);
    double sb[3] = {0, 0, 0}, sa[3] = {0, 0, 0};
    for (size_t i = 0; i < b.size(); ++i) sb[3 - b.size() + i] = b[i];
    for (size_t i = 0; i < a.size(); ++i) sa[3 - a.size() + i] = a[i];
    if (sa[0] != 1.0) throw std::logic_error("zpk2sos: section denominator is not monic (pairing bug)");
    return SosSection{sb[0], sb[1], sb[2], sa[1], sa[2]};
}

template <class T>
void erase_at(std::vector<T>& v, size_t i) {
    v.erase(v.begin() + static_cast<std::ptrdiff_t>(i));
}

// Numerator and denominator of a section at w = z - 1:
//   b0 z^2 + b1 z + b2 = b0 w^2 + (2 b0 + b1) w + (b0 + b1 + b2)
//   z^2 + a1 z + a2    = w^2 + (a1 + 2) w + (1 + a1 + a2)
// a1 + 2 and a2 - 1 are exact for poles near z = 1 (Sterbenz), so the
// low-frequency response keeps its accuracy.
cplx section_at_w(const SosSection& s, cplx w) {
    const double n1 = 2.0 * s.b0 + s.b1, n0 = (s.b0 + s.b1) + s.b2;
    const double d1 = s.a1 + 2.0, d0 = d1 + (s.a2 - 1.0);
    return ((s.b0 * w + n1) * w + n0) / ((w + d1) * w + d0);
}

cplx cascade_at_w(const std::vector<SosSection>& sections, cplx w, size_t count) {
    cplx v = 1.0;
    for (size_t i = 0; i < count; ++i) v *= section_at_w(sections[i], w);
    return v;
}

double max_pole_radius(const std::vector<SosSection>& sections) {
    double rho = 0.0;
    for (const SosSection& s : sections)
        for (const cplx& p : section_poles(s)) rho = std::max(rho, std::abs(p));
    return rho;
}

}  // namespace

std::vector<SosSection> zpk2sos(const Zpk& d, SosPadding padding) {
    if (!is_discrete(d.ts)) throw std::invalid_argument("zpk2sos: the model must be discrete (ts > 0)");
    if (!std::isfinite(d.gain)) throw std::invalid_argument("zpk2sos: gain must be finite");
    if (d.zeros.size() > d.poles.size())
        throw std::invalid_argument("zpk2sos: improper discrete model (more zeros than poles) is not causal");
    if (d.poles.empty()) return {SosSection{d.gain, 0.0, 0.0, 0.0, 0.0}};

    std::vector<cplx> zf = d.zeros, pf = d.poles;
    while (zf.size() < pf.size()) zf.emplace_back(0.0, 0.0);
    const size_t n_sections = (pf.size() + 1) / 2;
    if (pf.size() % 2 == 1) {
        pf.emplace_back(0.0, 0.0);
        zf.emplace_back(0.0, 0.0);
    }
    std::vector<cplx> z = cplxreal(zf), p = cplxreal(pf);
    std::vector<SosSection> sos(n_sections);
    for (size_t k = n_sections; k-- > 0;) {
        const size_t p1_idx = idx_worst(p);
        const cplx p1 = p[p1_idx];
        erase_at(p, p1_idx);
        const auto count_real = [](const std::vector<cplx>& v) {
            return static_cast<size_t>(std::count_if(v.begin(), v.end(), is_real));
        };
        if (is_real(p1) && count_real(p) == 0) {
            // Last remaining real pole: a first-order section.
            const size_t z1_idx = nearest_idx(z, p1, Which::kReal);
            const cplx z1 = z[z1_idx];
            erase_at(z, z1_idx);
            sos[k] = single_section({z1, 0.0}, {p1, 0.0});
        } else if (p.size() + 1 == z.size() && !is_real(p1) && count_real(p) == 1 && count_real(z) == 1) {
            // One real pole and one real zero left with as many poles as
            // zeros to pair: this complex pole must take a complex zero.
            const size_t z1_idx = nearest_idx(z, p1, Which::kComplex);
            const cplx z1 = z[z1_idx];
            erase_at(z, z1_idx);
            sos[k] = single_section({z1, std::conj(z1)}, {p1, std::conj(p1)});
        } else {
            cplx p2;
            if (is_real(p1)) {
                std::vector<size_t> real_idx;
                std::vector<cplx> real_p;
                for (size_t i = 0; i < p.size(); ++i)
                    if (is_real(p[i])) {
                        real_idx.push_back(i);
                        real_p.push_back(p[i]);
                    }
                const size_t p2_idx = real_idx[idx_worst(real_p)];
                p2 = p[p2_idx];
                erase_at(p, p2_idx);
            } else {
                p2 = std::conj(p1);
            }
            if (!z.empty()) {
                const size_t z1_idx = nearest_idx(z, p1, Which::kAny);
                const cplx z1 = z[z1_idx];
                erase_at(z, z1_idx);
                if (!is_real(z1)) {
                    sos[k] = single_section({z1, std::conj(z1)}, {p1, p2});
                } else if (!z.empty()) {
                    const size_t z2_idx = nearest_idx(z, p1, Which::kReal);
                    const cplx z2 = z[z2_idx];
                    erase_at(z, z2_idx);
                    sos[k] = single_section({z1, z2}, {p1, p2});
                } else {
                    sos[k] = single_section({z1}, {p1, p2});
                }
            } else {
                sos[k] = single_section({}, {p1, p2});
            }
        }
    }
    sos[0].b0 *= d.gain;
    sos[0].b1 *= d.gain;
    sos[0].b2 *= d.gain;
    if (padding == SosPadding::kDelay) {
        // Give back the relative degree as delays: a zero at z = 0 is b2 = 0
        // exactly; dropping it shifts the numerator one sample later.
        size_t missing = d.poles.size() - d.zeros.size();
        for (size_t i = 0; i < sos.size() && missing > 0; ++i) {
            while (missing > 0 && sos[i].b2 == 0.0 && (sos[i].b0 != 0.0 || sos[i].b1 != 0.0)) {
                sos[i].b2 = sos[i].b1;
                sos[i].b1 = sos[i].b0;
                sos[i].b0 = 0.0;
                --missing;
            }
        }
        if (missing != 0) throw std::logic_error("zpk2sos: padding zeros not found (pairing bug)");
    }
    return sos;
}

std::vector<cplx> section_poles_shifted(double c1, double c0) {
    // w^2 + c1 w + c0 = 0, w = z - 1.
    const double disc = c1 * c1 - 4.0 * c0;
    std::vector<cplx> w;
    if (disc < 0.0) {
        const double im = 0.5 * std::sqrt(-disc);
        w = {cplx(-0.5 * c1, im), cplx(-0.5 * c1, -im)};
    } else {
        // Stable form: the larger root by the formula, the other by c0 / q.
        const double q = -0.5 * (c1 + std::copysign(std::sqrt(disc), c1));
        if (q == 0.0)
            w = {cplx(0.0), cplx(0.0)};
        else
            w = {cplx(q), cplx(c0 / q)};
    }
    for (cplx& x : w) x += 1.0;
    return w;
}

std::vector<cplx> section_poles(const SosSection& s) {
    const double c1 = s.a1 + 2.0;
    return section_poles_shifted(c1, c1 + (s.a2 - 1.0));
}

Zpk sos2zpk(const std::vector<SosSection>& sections, double ts) {
    Zpk out;
    out.ts = ts;
    out.gain = 1.0;
    for (const SosSection& s : sections) {
        // Numerator b0 z^2 + b1 z + b2 (leading zeros: fewer finite zeros).
        std::vector<double> b{s.b0, s.b1, s.b2};
        size_t lead = 0;
        while (lead < b.size() && b[lead] == 0.0) ++lead;
        if (lead == b.size()) {
            out.gain = 0.0;
            out.zeros.clear();
            continue;
        }
        out.gain *= b[lead];
        std::vector<double> nb(b.begin() + static_cast<std::ptrdiff_t>(lead), b.end());
        for (const cplx& r : poly_roots(nb)) out.zeros.push_back(r);
        // H = (b0 z^2 + b1 z + b2) / (z^2 + a1 z + a2): with b0 = 0 the
        // section has fewer finite zeros than poles (a delay).
        for (const cplx& r : section_poles(s)) out.poles.push_back(r);
    }
    // Cancel exact pairs at z = 0 (padding of first-order sections).
    for (;;) {
        auto zi = std::find(out.zeros.begin(), out.zeros.end(), cplx(0.0));
        auto pi = std::find(out.poles.begin(), out.poles.end(), cplx(0.0));
        if (zi == out.zeros.end() || pi == out.poles.end()) break;
        out.zeros.erase(zi);
        out.poles.erase(pi);
    }
    if (out.gain == 0.0) out.zeros.clear();
    out.zeros = canonical_roots(out.zeros, "zeros");
    out.poles = canonical_roots(out.poles, "poles");
    return out;
}

cplx evaluate(const std::vector<SosSection>& sections, cplx z) {
    return cascade_at_w(sections, z - 1.0, sections.size());
}

std::vector<cplx> freqresp(const std::vector<SosSection>& sections, double ts, const std::vector<double>& w_rad_s) {
    std::vector<cplx> out;
    for (double w : w_rad_s) out.push_back(cascade_at_w(sections, expj_minus_one(w * ts), sections.size()));
    return out;
}

SosNorm parse_sos_norm(const std::string& name) {
    if (name == "l1" || name == "L1") return SosNorm::kL1;
    if (name == "linf" || name == "Linf") return SosNorm::kLinf;
    if (name == "none") return SosNorm::kNone;
    throw std::invalid_argument("scaling: must be one of l1, linf, none");
}

const char* sos_norm_name(SosNorm n) {
    switch (n) {
        case SosNorm::kL1: return "l1";
        case SosNorm::kLinf: return "linf";
        case SosNorm::kNone: return "none";
    }
    return "?";
}

std::vector<double> partial_l1_norms(const std::vector<SosSection>& sections, long max_samples, long* samples_used) {
    const size_t m = sections.size();
    const double rho = max_pole_radius(sections);
    if (!(rho < 1.0)) {
        if (samples_used) *samples_used = 0;
        return std::vector<double>(m, std::numeric_limits<double>::infinity());
    }
    // |h[n]| <~ n rho^n for double poles; 1e-13 of the start plus a margin.
    long n = rho == 0.0 ? 64 : static_cast<long>(std::ceil(std::log(1e-13) / std::log(rho))) + 64;
    n = std::min(std::max(n, 64L), max_samples);
    if (samples_used) *samples_used = n;
    std::vector<double> l1(m, 0.0);
    std::vector<SosStateDouble> st(m);
    for (long k = 0; k < n; ++k) {
        double x = k == 0 ? 1.0 : 0.0;
        for (size_t i = 0; i < m; ++i) {
            x = df2t_step(sections[i], st[i], x);
            l1[i] += std::fabs(x);
        }
    }
    return l1;
}

std::vector<double> partial_linf_norms(const std::vector<SosSection>& sections) {
    std::vector<double> theta;
    const int grid = 4000;
    for (int i = 0; i < grid; ++i)
        theta.push_back(std::numbers::pi * std::pow(10.0, -7.0 + 7.0 * i / (grid - 1)));
    theta.push_back(0.0);
    for (const SosSection& s : sections)
        for (const cplx& p : section_poles(s)) theta.push_back(std::fabs(std::arg(p)));
    std::vector<double> peak(sections.size(), 0.0);
    for (double t : theta) {
        const cplx w = expj_minus_one(t);
        cplx v = 1.0;
        for (size_t i = 0; i < sections.size(); ++i) {
            v *= section_at_w(sections[i], w);
            peak[i] = std::max(peak[i], std::abs(v));
        }
    }
    return peak;
}

std::vector<SosSection> scale_sos(const std::vector<SosSection>& sections, const SosScaling& sc,
                                  SosScalingReport* report) {
    if (!(sc.in_full_scale > 0.0) || !std::isfinite(sc.in_full_scale))
        throw std::invalid_argument("in_full_scale: must be finite and > 0");
    if (!(sc.out_full_scale > 0.0) || !std::isfinite(sc.out_full_scale))
        throw std::invalid_argument("out_full_scale: must be finite and > 0");
    if (!(sc.headroom > 0.0 && sc.headroom <= 1.0)) throw std::invalid_argument("headroom: must be in (0, 1]");
    const double io = sc.in_full_scale / sc.out_full_scale;
    std::vector<double> norms;
    long samples = 0;
    if (sc.norm == SosNorm::kL1 || sc.norm == SosNorm::kNone)
        norms = partial_l1_norms(sections, 20'000'000, &samples);
    else
        norms = partial_linf_norms(sections);
    for (double& v : norms) v *= io;
    std::vector<SosSection> out = sections;
    const size_t m = sections.size();
    const bool finite = std::all_of(norms.begin(), norms.end(), [](double v) { return std::isfinite(v); });
    if (sc.norm != SosNorm::kNone && finite && m > 1) {
        double applied = 1.0;  // product of the factors so far
        for (size_t k = 0; k + 1 < m; ++k) {
            const double current = norms[k] * applied;
            const double c = current > 0.0 ? sc.headroom / current : 1.0;
            out[k].b0 *= c;
            out[k].b1 *= c;
            out[k].b2 *= c;
            applied *= c;
            norms[k] = current * c;
        }
        const double last = 1.0 / applied;
        out[m - 1].b0 *= last;
        out[m - 1].b1 *= last;
        out[m - 1].b2 *= last;
    }
    if (report) {
        report->partial_norms = norms;
        report->output_may_saturate = !(norms.back() <= 1.0);
        report->impulse_samples = samples;
    }
    return out;
}

}  // namespace piezoloop::design
