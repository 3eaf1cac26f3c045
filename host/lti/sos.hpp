// Discrete Zpk -> cascade of second-order sections (docs/models.md, 'Biquad cascades'), and the
// per-section scaling for fixed point.
//
// Pairing and ordering follow scipy.signal.zpk2sos(pairing='nearest')
// exactly (tests/golden/design_sos.json checks it): sections are built
// from the pole nearest the unit circle (min |1 - |p||) outwards; each gets
// the zero nearest to that pole (a complex zero brings its conjugate, a real
// one the next nearest real zero); missing zeros are padded at z = 0. The
// section with the poles nearest the unit circle comes LAST, so the
// high-gain, slowly decaying sections see signals already shaped by the
// others. The gain sits in the first section until scale_sos() spreads it.
//
// Scaling (scale_sos): the sections' numerators are multiplied by factors
// whose product is 1 (the cascade's response is unchanged) so that every
// partial cascade P_k = H_0 … H_k except the last has norm
// |P_k| * in_full_scale / out_full_scale = headroom: its node reaches, but
// does not exceed, the Q31 full scale for any input within full scale. The
// norm is L1 (sum of |impulse response|, the exact worst case over all
// bounded inputs: the default, docs/models.md's "no internal node overflows for a
// full-scale input") or L∞ (peak of |P_k(e^{jw})|, which bounds
// sinusoidal inputs only and leaves more resolution). The last node is the
// output: its norm is the design's and is reported, not changed.
#pragma once

#include <string>
#include <vector>

#include "lti/lti.hpp"
#include "piezoloop/biquad.hpp"

namespace piezoloop::design {

// Zeros missing for a strictly proper model (fewer zeros than poles) are
// zeros at infinity, i.e. delays. scipy pads them as zeros at z = 0 for the
// pairing and keeps them there, which advances the response by one sample
// per missing zero (scipy reads equal-length b, a as polynomials in z^-1).
// kDelay (default) pairs exactly as scipy, then removes those padding
// zeros again by shifting the numerators of the first sections that hold a
// zero at z = 0 one place later (b0 z^-0 -> z^-1): the cascade realises
// exactly gain * prod(z - z_i) / prod(z - p_i). kScipy keeps scipy's result.
enum class SosPadding { kDelay, kScipy };

// Requires a discrete (ts > 0), proper model. At least one section.
std::vector<SosSection> zpk2sos(const Zpk& discrete, SosPadding padding = SosPadding::kDelay);

// The cascade as a discrete Zpk (roots of each section; padding roots at
// z = 0 that cancel are removed).
Zpk sos2zpk(const std::vector<SosSection>& sections, double ts);

// Response of the cascade at z (double arithmetic on the coefficients,
// each section evaluated in w = z - 1 so poles near z = 1 keep accuracy).
cplx evaluate(const std::vector<SosSection>& sections, cplx z);
// At z = e^{jw ts} for each w (rad/s), with e^{jw ts} - 1 formed directly.
std::vector<cplx> freqresp(const std::vector<SosSection>& sections, double ts, const std::vector<double>& w_rad_s);

// Poles of one section (two roots, a first-order section has one at 0),
// computed in w = z - 1 so that poles near z = 1 keep their accuracy:
// w^2 + c1 w + c0 with c1 = a1 + 2 and c0 = 1 + a1 + a2.
std::vector<cplx> section_poles_shifted(double c1, double c0);
std::vector<cplx> section_poles(const SosSection& s);

enum class SosNorm { kL1, kLinf, kNone };
SosNorm parse_sos_norm(const std::string& name);  // "l1" | "linf" | "none"
const char* sos_norm_name(SosNorm n);

struct SosScaling {
    SosNorm norm = SosNorm::kL1;
    double in_full_scale = 1.0;   // physical input that maps to Q31 full scale
    double out_full_scale = 1.0;  // physical output (and internal nodes) at Q31 full scale
    double headroom = 1.0;        // target norm of the internal nodes, in (0, 1]
};

struct SosScalingReport {
    // Norm of every partial cascade after scaling, in sample units
    // (times in/out full scale); the last one is the output's.
    std::vector<double> partial_norms;
    bool output_may_saturate = false;  // last partial norm > 1
    long impulse_samples = 0;          // length used for the L1 norms
};

std::vector<SosSection> scale_sos(const std::vector<SosSection>& sections, const SosScaling& scaling,
                                  SosScalingReport* report = nullptr);

// One section in double, direct form II transposed: the reference the design
// tools simulate cascades with (impulse responses, norms, noise gains).
struct SosStateDouble {
    double s1 = 0.0, s2 = 0.0;
};
inline double df2t_step(const SosSection& c, SosStateDouble& s, double x) {
    const double y = c.b0 * x + s.s1;
    s.s1 = c.b1 * x - c.a1 * y + s.s2;
    s.s2 = c.b2 * x - c.a2 * y;
    return y;
}

// Norms of all partial cascades (unscaled units, no full scales applied).
// L1: impulse response simulated in double until it has decayed to 1e-13
// of its start (from the largest pole radius), at most max_samples.
std::vector<double> partial_l1_norms(const std::vector<SosSection>& sections, long max_samples = 20'000'000,
                                     long* samples_used = nullptr);
// L∞: peak over 4000 log-spaced frequencies from 1e-7 to 1 times Nyquist
// plus every section pole's angle (where resonances peak).
std::vector<double> partial_linf_norms(const std::vector<SosSection>& sections);

}  // namespace piezoloop::design
