#include "measure/mimo_frf_estimate.hpp"

#include <cmath>
#include <complex>
#include <limits>
#include <stdexcept>
#include <string>

#include <unsupported/Eigen/FFT>

namespace piezoloop::measure {

namespace {

using Records = std::vector<std::vector<std::vector<double>>>;

void check_records(const MimoFrfPlan& plan, const Records& x, const char* name, std::size_t channels_min,
                   std::size_t channels_max) {
    const auto n = static_cast<std::size_t>(plan.inputs);
    if (x.size() != n)
        throw std::invalid_argument(std::string(name) + ": must hold the plan's " + std::to_string(n) + " blocks (got " +
                                    std::to_string(x.size()) + ")");
    for (std::size_t b = 0; b < n; ++b) {
        const std::string where = std::string(name) + "[" + std::to_string(b) + "]";
        if (x[b].size() < channels_min || x[b].size() > channels_max || x[b].size() != x[0].size())
            throw std::invalid_argument(where + ": must hold " +
                                        (channels_min == channels_max ? std::to_string(channels_min)
                                                                      : "1 to " + std::to_string(channels_max)) +
                                        " channels, the same in every block (got " + std::to_string(x[b].size()) + ")");
        for (std::size_t c = 0; c < x[b].size(); ++c)
            if (x[b][c].size() != plan.block_samples)
                throw std::invalid_argument(where + "[" + std::to_string(c) + "]: must hold the block's " +
                                            std::to_string(plan.block_samples) + " samples (got " +
                                            std::to_string(x[b][c].size()) + ")");
    }
}

// spectra[line][period](channel, block) of the measured periods, peak units.
void add_spectra(const MimoFrfPlan& plan, const Records& x, std::vector<std::vector<Eigen::MatrixXcd>>& spectra) {
    const std::size_t N = plan.layout.period_samples, K = plan.frequency_Hz.size();
    const auto P = static_cast<std::size_t>(plan.periods);
    const std::size_t blocks = x.size(), channels = x[0].size();
    spectra.assign(K, std::vector<Eigen::MatrixXcd>(P, Eigen::MatrixXcd::Zero(static_cast<Eigen::Index>(channels),
                                                                             static_cast<Eigen::Index>(blocks))));
    Eigen::FFT<double> fft;
    std::vector<double> seg(N);
    std::vector<std::complex<double>> spec;
    const double to_peak = 2.0 / static_cast<double>(N);
    for (std::size_t b = 0; b < blocks; ++b)
        for (std::size_t c = 0; c < channels; ++c)
            for (std::size_t p = 0; p < P; ++p) {
                const auto start = static_cast<std::ptrdiff_t>(plan.measured_start + p * N);
                std::copy(x[b][c].begin() + start, x[b][c].begin() + start + static_cast<std::ptrdiff_t>(N), seg.begin());
                fft.fwd(spec, seg);
                for (std::size_t j = 0; j < K; ++j)
                    spectra[j][p](static_cast<Eigen::Index>(c), static_cast<Eigen::Index>(b)) =
                        spec[plan.layout.first_bin + j] * to_peak;
            }
}

Eigen::MatrixXcd mean_of(const std::vector<Eigen::MatrixXcd>& v) {
    Eigen::MatrixXcd m = Eigen::MatrixXcd::Zero(v[0].rows(), v[0].cols());
    for (const Eigen::MatrixXcd& x : v) m += x;
    return m / static_cast<double>(v.size());
}

}  // namespace

MimoFrfEstimate estimate_mimo_frf(const MimoFrfPlan& plan, const Records& u, const Records& y) {
    if (plan.inputs < 1 || plan.periods < 1 || plan.frequency_Hz.empty())
        throw std::invalid_argument("plan: not a plan from plan_mimo_frf");
    const auto n = static_cast<std::size_t>(plan.inputs);
    check_records(plan, u, "u", n, n);
    check_records(plan, y, "y", 1, 16);
    std::vector<std::vector<Eigen::MatrixXcd>> us, ys;
    add_spectra(plan, u, us);
    add_spectra(plan, y, ys);
    MimoFrfEstimate e;
    e.inputs = plan.inputs;
    e.outputs = static_cast<int>(y[0].size());
    e.periods = plan.periods;
    e.rate_Hz = plan.layout.rate_Hz;
    e.frequency_Hz = plan.frequency_Hz;
    const double nan = std::numeric_limits<double>::quiet_NaN();
    const auto P = static_cast<std::size_t>(plan.periods);
    for (std::size_t j = 0; j < plan.frequency_Hz.size(); ++j) {
        const Eigen::MatrixXcd ub = mean_of(us[j]), yb = mean_of(ys[j]);
        const Eigen::JacobiSVD<Eigen::MatrixXcd> svd(ub);
        const double smax = svd.singularValues()(0), smin = svd.singularValues()(ub.cols() - 1);
        if (!(smin > 1e-12 * smax) || !std::isfinite(smax))
            throw std::invalid_argument("u: the measured input matrix is singular at " + std::to_string(plan.frequency_Hz[j]) +
                                        " Hz (inputs not excited as planned?)");
        const Eigen::MatrixXcd g = yb * ub.inverse();
        Eigen::MatrixXd sd = Eigen::MatrixXd::Constant(g.rows(), g.cols(), nan);
        if (P >= 2) {
            std::vector<Eigen::MatrixXcd> gp;
            for (std::size_t p = 0; p < P; ++p) gp.push_back(ys[j][p] * us[j][p].inverse());
            const Eigen::MatrixXcd gm = mean_of(gp);
            Eigen::MatrixXd ss = Eigen::MatrixXd::Zero(g.rows(), g.cols());
            for (const Eigen::MatrixXcd& x : gp) ss += (x - gm).cwiseAbs2();
            sd = (ss / (static_cast<double>(P) * static_cast<double>(P - 1))).cwiseSqrt();
        }
        Eigen::MatrixXd snr(g.rows(), g.cols());
        for (Eigen::Index r = 0; r < g.rows(); ++r)
            for (Eigen::Index c = 0; c < g.cols(); ++c)
                snr(r, c) = 20.0 * std::log10(std::abs(g(r, c)) / sd(r, c));
        e.response.push_back(g);
        e.std_dev.push_back(sd);
        e.snr_db.push_back(snr);
        e.input_condition.push_back(smax / smin);
    }
    return e;
}

}  // namespace piezoloop::measure
