#include "measure/frf_estimate.hpp"

#include <algorithm>
#include <cmath>
#include <limits>
#include <stdexcept>
#include <string>

#include <unsupported/Eigen/FFT>

#include "measure/welch_segments.hpp"

namespace piezoloop::measure {

namespace {

// The first half of the periods against the second (frf_estimate.hpp).
void transient_check(const std::vector<std::vector<cplx>>& U, const std::vector<std::vector<cplx>>& Y, FrfEstimate& e) {
    const std::size_t P = U.size(), n = P / 2, K = e.response.size(), b0 = P - n;
    std::vector<cplx> change(K);
    std::vector<double> spread(K);
    for (std::size_t j = 0; j < K; ++j) {
        cplx ua = 0.0, ya = 0.0, ub = 0.0, yb = 0.0;
        for (std::size_t p = 0; p < n; ++p) {
            ua += U[p][j];
            ya += Y[p][j];
            ub += U[b0 + p][j];
            yb += Y[b0 + p][j];
        }
        const cplx gb = yb / ub;
        change[j] = ya / ua - gb;
        double s = 0.0;
        for (std::size_t p = b0; p < P; ++p) s += std::norm(Y[p][j] / U[p][j] - gb);
        spread[j] = s / static_cast<double>(n - 1);
        e.half_change_rel.push_back(std::abs(change[j]) / std::abs(gb));
    }
    for (std::size_t j = 0; j < K; ++j) {
        const std::size_t lo = j >= static_cast<std::size_t>(kTransientPool) ? j - kTransientPool : 0;
        const std::size_t hi = std::min(K - 1, j + kTransientPool);
        double pooled = 0.0;
        for (std::size_t i = lo; i <= hi; ++i) pooled += spread[i];
        pooled /= static_cast<double>(hi - lo + 1);
        const double var_change = 2.0 * pooled / static_cast<double>(n);
        if (e.half_change_rel[j] >= kTransientRel && std::norm(change[j]) > kTransientZ2 * var_change)
            e.transient_lines.push_back(j);
    }
}

}  // namespace

FrfEstimate estimate_multisine(const std::vector<double>& u, const std::vector<double>& y, const MultisineLayout& l) {
    const std::size_t N = l.period_samples;
    if (N < 4 || l.first_bin < 1 || l.last_bin < l.first_bin || 2 * std::size_t{l.last_bin} >= N)
        throw std::invalid_argument("multisine layout: need 1 <= first_bin <= last_bin < N / 2");
    if (u.size() != y.size() || u.empty() || u.size() % N != 0)
        throw std::invalid_argument("multisine record: u and y must hold the same whole number of periods (" +
                                    std::to_string(u.size()) + ", " + std::to_string(y.size()) + " samples, N = " +
                                    std::to_string(N) + ")");
    const std::size_t P = u.size() / N;
    const std::size_t K = l.last_bin - l.first_bin + 1;
    // Per-period spectra at the excited bins (one FFT of each period: the
    // bins fall exactly on the DFT grid, no window, no leakage).
    std::vector<std::vector<cplx>> U(P, std::vector<cplx>(K)), Y(P, std::vector<cplx>(K));
    Eigen::FFT<double> fft;
    std::vector<double> seg(N);
    std::vector<cplx> spec;
    const double to_peak = 2.0 / static_cast<double>(N);
    for (std::size_t p = 0; p < P; ++p) {
        for (int which = 0; which < 2; ++which) {
            const std::vector<double>& x = which == 0 ? u : y;
            std::copy(x.begin() + static_cast<std::ptrdiff_t>(p * N), x.begin() + static_cast<std::ptrdiff_t>((p + 1) * N),
                      seg.begin());
            fft.fwd(spec, seg);
            std::vector<cplx>& dst = which == 0 ? U[p] : Y[p];
            for (std::size_t j = 0; j < K; ++j) dst[j] = spec[l.first_bin + j] * to_peak;
        }
    }
    FrfEstimate e;
    e.periods = static_cast<int>(P);
    const double nan = std::numeric_limits<double>::quiet_NaN();
    const double db_per_rel = 20.0 / std::log(10.0);
    for (std::size_t j = 0; j < K; ++j) {
        cplx ub = 0.0, yb = 0.0;
        for (std::size_t p = 0; p < P; ++p) {
            ub += U[p][j];
            yb += Y[p][j];
        }
        ub /= static_cast<double>(P);
        yb /= static_cast<double>(P);
        double vu = nan, vy = nan;
        cplx cyu = nan;
        if (P >= 2) {
            vu = vy = 0.0;
            cyu = 0.0;
            for (std::size_t p = 0; p < P; ++p) {
                const cplx du = U[p][j] - ub, dy = Y[p][j] - yb;
                vu += std::norm(du);
                vy += std::norm(dy);
                cyu += dy * std::conj(du);
            }
            // Variances of the means: the sample variance over P periods / P.
            const double s = 1.0 / (static_cast<double>(P) * static_cast<double>(P - 1));
            vu *= s;
            vy *= s;
            cyu *= s;
        }
        const cplx g = yb / ub;
        double var_g = std::norm(g) * (vy / std::norm(yb) + vu / std::norm(ub) -
                                       2.0 * (cyu / (yb * std::conj(ub))).real());
        if (var_g < 0.0) var_g = 0.0;  // rounding, when u is noise-free and y nearly so
        const double rel = std::sqrt(var_g) / std::abs(g);
        e.frequency_Hz.push_back(static_cast<double>(l.first_bin + j) * l.rate_Hz / static_cast<double>(N));
        e.response.push_back(g);
        e.var.push_back(var_g);
        e.std_db.push_back(db_per_rel * rel);
        e.snr_db.push_back(rel > 0.0 ? -20.0 * std::log10(rel) : std::numeric_limits<double>::infinity());
        e.u_line.push_back(ub);
        e.y_line.push_back(yb);
    }
    if (P >= 4) transient_check(U, Y, e);
    return e;
}

WelchEstimate estimate_h1(const std::vector<double>& u, const std::vector<double>& y, double rate_Hz, uint32_t segment,
                          double from_Hz, double to_Hz) {
    const std::size_t L = segment, hop = segment / 2;
    if (L < 8 || u.size() != y.size() || u.size() < L)
        throw std::invalid_argument("welch: u and y must have the same length, at least one segment of >= 8 samples");
    const std::size_t bins = L / 2 + 1;
    std::vector<double> suu(bins, 0.0), syy(bins, 0.0);
    std::vector<cplx> syu(bins, 0.0);
    WelchEstimate e;
    e.segments = for_each_welch_segment<double>({u, y}, hann_window(L), hop, [&](const auto& spectra) {
        const std::vector<cplx>& xu = spectra[0];
        const std::vector<cplx>& xy = spectra[1];
        for (std::size_t k = 0; k < bins; ++k) {
            suu[k] += std::norm(xu[k]);
            syy[k] += std::norm(xy[k]);
            syu[k] += xy[k] * std::conj(xu[k]);
        }
    });
    e.segment_samples = segment;
    e.periods = 0;
    const double db_per_rel = 20.0 / std::log(10.0);
    for (std::size_t k = 1; k < bins; ++k) {
        const double f = static_cast<double>(k) * rate_Hz / static_cast<double>(L);
        if (f < from_Hz * (1.0 - 1e-12) || f > to_Hz * (1.0 + 1e-12)) continue;
        const cplx h = syu[k] / suu[k];
        const double coh = std::min(1.0, std::norm(syu[k]) / (suu[k] * syy[k]));
        const double rel = std::sqrt((1.0 - coh) / (2.0 * e.segments * coh));
        e.frequency_Hz.push_back(f);
        e.response.push_back(h);
        e.coherence.push_back(coh);
        e.var.push_back(std::norm(h) * rel * rel);
        e.std_db.push_back(db_per_rel * rel);
        e.snr_db.push_back(rel > 0.0 ? -20.0 * std::log10(rel) : std::numeric_limits<double>::infinity());
    }
    if (e.frequency_Hz.empty()) throw std::invalid_argument("welch: no FFT bin between from_Hz and to_Hz");
    return e;
}

}  // namespace piezoloop::measure
