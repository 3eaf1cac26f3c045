#include "measure/mimo_frf_plan.hpp"

#include <algorithm>
#include <cmath>
#include <complex>
#include <numbers>
#include <stdexcept>
#include <string>

#include <unsupported/Eigen/FFT>

#include "format/number.hpp"
#include "measure/frf_plan.hpp"
#include "measure/record_bound.hpp"
#include "options/option_checks.hpp"

namespace piezoloop::measure {

namespace {

// The longest period, samples: one period is synthesised by an FFT of N
// points (2^17: a line spacing of 0.076 Hz at 10 kHz).
constexpr double kMaxPeriodSamples = 131072.0;


using options::refuse;

// sum_{k=k1..k2} cos(2 pi k t / N + phi_j + shift), t = 0..N-1, by one
// inverse DFT (Eigen's inverse divides by N).
std::vector<double> unit_period(const MimoFrfPlan& p, double shift_rad) {
    const std::size_t N = p.layout.period_samples;
    std::vector<std::complex<double>> spectrum(N, 0.0), x;
    for (std::size_t j = 0; j < p.schroeder_rad.size(); ++j) {
        const std::size_t k = p.layout.first_bin + j;
        const std::complex<double> c = std::polar(0.5 * static_cast<double>(N), p.schroeder_rad[j] + shift_rad);
        spectrum[k] = c;
        spectrum[N - k] = std::conj(c);
    }
    Eigen::FFT<double> fft;
    fft.inv(x, spectrum);
    std::vector<double> out(N);
    for (std::size_t t = 0; t < N; ++t) out[t] = x[t].real();
    return out;
}

double block_shift_rad(const MimoFrfPlan& p, int block, int input) {
    return 2.0 * std::numbers::pi * static_cast<double>(block * input) / static_cast<double>(p.inputs);
}

}  // namespace

MimoFrfPlan plan_mimo_frf(const MimoFrfRequest& r) {
    if (r.inputs < 1 || r.inputs > 3) refuse("inputs", "must be 1, 2 or 3 (got " + std::to_string(r.inputs) + ")");
    if (!std::isfinite(r.rate_Hz) || !(r.rate_Hz > 0.0) || r.rate_Hz > 1e9) refuse("rate_Hz", "must be in (0, 1e9] Hz");
    const double nyq = 0.5 * r.rate_Hz;
    if (!std::isfinite(r.from_Hz) || !(r.from_Hz >= r.rate_Hz / kMaxPeriodSamples))
        refuse("from_Hz", "must be >= rate / " + format::significant(kMaxPeriodSamples) + " = " + format::significant(r.rate_Hz / kMaxPeriodSamples) +
                              " Hz (the longest period)");
    if (!std::isfinite(r.to_Hz) || !(r.to_Hz < nyq))
        refuse("to_Hz", "must be below the Nyquist frequency, rate / 2 = " + format::significant(nyq) + " Hz");
    if (!(r.from_Hz < r.to_Hz)) refuse("from_Hz", "must be below to_Hz (" + format::significant(r.to_Hz) + " Hz)");
    if (!std::isfinite(r.amplitude_V) || !(r.amplitude_V > 0.0) || r.amplitude_V > 1e6)
        refuse("amplitude_V", "must be in (0, 1e6] V");
    if (!r.bias_V.empty() && r.bias_V.size() != static_cast<std::size_t>(r.inputs))
        refuse("bias_V", "must have one entry per input (" + std::to_string(r.inputs) + ") or none");
    for (std::size_t i = 0; i < r.bias_V.size(); ++i)
        if (!std::isfinite(r.bias_V[i]) || std::fabs(r.bias_V[i]) > 1e6)
            refuse("bias_V[" + std::to_string(i) + "]", "must be finite, within +-1e6 V");
    if (r.periods < 1 || r.periods > 10000) refuse("periods", "must be in [1, 10000]");
    if (r.transient_periods < 0 || r.transient_periods > 100) refuse("transient_periods", "must be in [0, 100]");

    MimoFrfPlan p;
    p.inputs = r.inputs;
    try {
        p.layout = multisine_lines(r.rate_Hz, r.from_Hz, r.to_Hz);
    } catch (const std::invalid_argument&) {
        refuse("to_Hz", "no DFT line between from_Hz and to_Hz at a spacing of " +
                            format::significant(r.rate_Hz / std::floor(r.rate_Hz / r.from_Hz + 1e-9)) + " Hz");
    }
    const uint64_t N = p.layout.period_samples;
    p.periods = r.periods;
    p.transient_periods = r.transient_periods;
    p.block_samples = N * static_cast<uint64_t>(r.periods + r.transient_periods);
    p.measured_start = N * static_cast<uint64_t>(r.transient_periods);
    if (p.block_samples > kMaxRecordTicks)
        refuse("periods", "(transient_periods + periods) x " + std::to_string(N) + " samples a period = " +
                              std::to_string(p.block_samples) + " samples a block exceeds the longest record, " +
                              std::to_string(kMaxRecordTicks) + ": lower periods or raise from_Hz");
    p.bias_V = r.bias_V.empty() ? std::vector<double>(static_cast<std::size_t>(r.inputs), 0.0) : r.bias_V;
    const uint32_t K = p.layout.last_bin - p.layout.first_bin + 1;
    for (uint32_t j = 0; j < K; ++j) {
        // j (j + 1) mod 2K first, as the core does, so phi stays in (-2 pi, 0].
        const uint64_t b = (uint64_t{j} * (j + 1u)) % (2u * uint64_t{K});
        p.schroeder_rad.push_back(-std::numbers::pi * static_cast<double>(b) / static_cast<double>(K));
        p.frequency_Hz.push_back(static_cast<double>(p.layout.first_bin + j) * r.rate_Hz / static_cast<double>(N));
    }
    // One amplitude for every line, input and block: the largest peak.
    double peak = 0.0;
    for (int b = 0; b < p.inputs; ++b)
        for (int l = 0; l < p.inputs; ++l)
            for (const double x : unit_period(p, block_shift_rad(p, b, l))) peak = std::max(peak, std::fabs(x));
    p.line_amplitude_V = r.amplitude_V / peak;
    return p;
}

std::vector<double> mimo_period(const MimoFrfPlan& p, int block, int input) {
    if (block < 0 || block >= p.inputs) throw std::invalid_argument("block: must be in [0, " + std::to_string(p.inputs) + ")");
    if (input < 0 || input >= p.inputs) throw std::invalid_argument("input: must be in [0, " + std::to_string(p.inputs) + ")");
    std::vector<double> x = unit_period(p, block_shift_rad(p, block, input));
    for (double& v : x) v = p.bias_V[static_cast<std::size_t>(input)] + p.line_amplitude_V * v;
    return x;
}

std::vector<std::vector<double>> mimo_block(const MimoFrfPlan& p, int block) {
    std::vector<std::vector<double>> out;
    for (int l = 0; l < p.inputs; ++l) {
        const std::vector<double> period = mimo_period(p, block, l);
        std::vector<double> x;
        x.reserve(p.block_samples);
        for (int q = 0; q < p.periods + p.transient_periods; ++q) x.insert(x.end(), period.begin(), period.end());
        out.push_back(std::move(x));
    }
    return out;
}

}  // namespace piezoloop::measure
