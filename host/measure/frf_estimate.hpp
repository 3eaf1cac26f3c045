// Nonparametric frequency response from recorded arrays, shared by
// every source of data: the simulator (frf_sim.hpp) and, later, a board's
// recording over the link. Nothing here knows where u and y came from.
//
// Periodic multisine (Pintelon & Schoukens, System Identification: A
// Frequency Domain Approach, 2nd ed., Wiley 2012, ch. 2, "Measurement of
// frequency response functions: the periodic excitation"): the record holds
// P whole periods of N samples after the transient was discarded; per period
// p the DFT at the excited bins gives U_p(k), Y_p(k); their means over the
// periods give
//     G(k) = Ybar(k) / Ubar(k)
// and the sample (co)variances of the means, from the period-to-period
// spread (P - 1 degrees of freedom),
//     var Ubar = sum |U_p - Ubar|^2 / (P (P - 1)), likewise var Ybar, cov(Y, U),
// the variance of G to first order
//     var G = |G|^2 (var Ybar / |Ybar|^2 + var Ubar / |Ubar|^2
//                    - 2 Re(cov(Ybar, Ubar) / (Ybar conj(Ubar)))).
// The noise on u (in closed loop it carries the fed-back noise) is accounted
// for, so the same estimate serves open and closed loops (ch. 2.6: with a
// periodic excitation Ybar / Ubar is consistent in feedback as well, the
// noise averaging out over the periods).
//
// Transient check (P >= 4): in steady state every period is the same but
// for noise, so a response that differs between the first and the second
// half of the periods beyond the noise is a transient still decaying (a
// lightly damped mode ringing from how the run started, a hysteretic or
// creeping stage still moving; Pintelon & Schoukens 2012, ch. 2, compare
// periods to see it). Per line, with n = P / 2 periods in each half, G_a
// and G_b the halves' estimates and s_b^2 the second half's
// period-to-period variance of Y_p / U_p, averaged over
// the kTransientPool lines each side (the noise varies slowly with
// frequency; one line's n - 1 degrees of freedom are too few):
//     z^2 = |G_a - G_b|^2 / (2 s_b^2 / n).
// For complex Gaussian noise z^2 is about F(2, 2 (n - 1) (2 kTransientPool
// + 1)) distributed: above kTransientZ2 with a probability below 1e-6 per
// line for n >= 2. A line is flagged when z^2 > kTransientZ2 and the change
// is at least kTransientRel of |G_b| (a bias that matters, not rounding).
#pragma once

#include <complex>
#include <cstdint>
#include <vector>

namespace piezoloop::measure {

using cplx = std::complex<double>;

struct MultisineLayout {
    double rate_Hz = 0.0;
    uint32_t period_samples = 0;  // N
    uint32_t first_bin = 1, last_bin = 1;  // excited DFT bins k1..k2 of N
};

inline constexpr int kTransientPool = 8;
inline constexpr double kTransientZ2 = 25.0;
inline constexpr double kTransientRel = 0.01;

struct FrfEstimate {
    std::vector<double> frequency_Hz;
    std::vector<cplx> response;   // G at each excited line
    std::vector<double> var;      // variance of G (|.|^2 units), per line
    std::vector<double> std_db;   // 20 log10(e) sigma_G / |G|: the magnitude's standard deviation in dB
    std::vector<double> snr_db;   // 20 log10(|G| / sigma_G)
    std::vector<cplx> u_line, y_line;  // mean DFT amplitudes (peak units: 2 |X| / N)
    int periods = 0;
    // The transient check (above; multisine with P >= 4, else empty): per
    // line |G_a - G_b| / |G_b|, and the indices of the lines flagged.
    std::vector<double> half_change_rel;
    std::vector<std::size_t> transient_lines;
};

// u, y: P * N samples (P >= 2 for the variances; P = 1 gives var = NaN).
// Throws std::invalid_argument when the lengths do not fit the layout.
FrfEstimate estimate_multisine(const std::vector<double>& u, const std::vector<double>& y, const MultisineLayout& l);

// Swept sine and PRBS: the H1 estimate with Welch averaging (P. D. Welch,
// IEEE Trans. Audio Electroacoust. 15(2), 1967; J. S. Bendat, A. G. Piersol,
// Random Data, 4th ed., Wiley 2010, ch. 9): segments of `segment` samples,
// half overlapping, mean removed, Hann window; auto and cross spectra summed
// over the segments give
//     H1 = S_yu / S_uu,   coherence = |S_yu|^2 / (S_uu S_yy),
// and the random error of |H1| (Bendat & Piersol 2010, table 9.6)
//     sigma_|H| / |H| = sqrt((1 - coherence) / (2 n_d coherence)),
// n_d the number of segments (taken as independent: with half overlap and a
// Hann window they nearly are). Lines: the FFT bins in [from_Hz, to_Hz].
struct WelchEstimate : FrfEstimate {
    std::vector<double> coherence;
    int segments = 0;
    uint32_t segment_samples = 0;
};
WelchEstimate estimate_h1(const std::vector<double>& u, const std::vector<double>& y, double rate_Hz, uint32_t segment,
                          double from_Hz, double to_Hz);

}  // namespace piezoloop::measure
