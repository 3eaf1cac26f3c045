// The MIMO systems of tests/golden/mimo_frf_ref.json (tools/ref/mimo_frf_ref.py):
// their exact response per line, and a simulation of their difference
// equations on recorded inputs, shared by the MIMO frequency-response tests.
#pragma once

#include <cmath>
#include <complex>
#include <vector>

#include <Eigen/Dense>
#include <nlohmann/json.hpp>

#include "measure/mimo_frf_plan.hpp"
#include "test_support.hpp"

namespace piezoloop::test {

struct MimoCase {
    nlohmann::json j;
    int n = 0;
    std::vector<double> f_Hz;
    std::vector<Eigen::MatrixXcd> g;  // exact, per line
    double pole_radius = 0.0;
};

inline MimoCase mimo_case(int index) {
    MimoCase c;
    c.j = load_golden("mimo_frf_ref")["cases"][static_cast<std::size_t>(index)];
    c.n = c.j["n"].get<int>();
    c.f_Hz = c.j["frequency_Hz"].get<std::vector<double>>();
    c.pole_radius = c.j["pole_radius"].get<double>();
    for (std::size_t k = 0; k < c.f_Hz.size(); ++k) {
        Eigen::MatrixXcd m(c.n, c.n);
        for (int i = 0; i < c.n; ++i)
            for (int l = 0; l < c.n; ++l)
                m(i, l) = {c.j["response_re"][k][i][l].get<double>(), c.j["response_im"][k][i][l].get<double>()};
        c.g.push_back(m);
    }
    return c;
}

// The request for the case's lines (10 Hz to 2 kHz at 10 kHz).
inline measure::MimoFrfRequest mimo_request(const MimoCase& c, int periods, int transient_periods) {
    measure::MimoFrfRequest r;
    r.inputs = c.n;
    r.rate_Hz = c.j["rate_Hz"].get<double>();
    r.from_Hz = c.j["from_Hz"].get<double>();
    r.to_Hz = c.j["to_Hz"].get<double>();
    r.amplitude_V = 1.0;
    r.periods = periods;
    r.transient_periods = transient_periods;
    return r;
}

// y = b(z) / a(z) u, from rest (direct form II transposed, as scipy's lfilter).
inline std::vector<double> lfilter(const std::vector<double>& b, const std::vector<double>& a, const std::vector<double>& u) {
    const std::size_t order = a.size() - 1;
    std::vector<double> z(order + 1, 0.0), y(u.size());
    for (std::size_t t = 0; t < u.size(); ++t) {
        const double out = (b[0] * u[t] + z[0]) / a[0];
        for (std::size_t m = 0; m < order; ++m) z[m] = b[m + 1] * u[t] + z[m + 1] - a[m + 1] * out;
        y[t] = out;
    }
    return y;
}

// Per block: y_i = sum_l G_il u_l, every element from rest at the block's start.
inline std::vector<std::vector<std::vector<double>>> mimo_simulate(const MimoCase& c,
                                                                   const std::vector<std::vector<std::vector<double>>>& u) {
    std::vector<std::vector<std::vector<double>>> y;
    for (const auto& block : u) {
        std::vector<std::vector<double>> yb(static_cast<std::size_t>(c.n), std::vector<double>(block[0].size(), 0.0));
        for (int i = 0; i < c.n; ++i)
            for (int l = 0; l < c.n; ++l) {
                const auto& e = c.j["elements"][i][l];
                const std::vector<double> part =
                    lfilter(e["b"].get<std::vector<double>>(), e["a"].get<std::vector<double>>(), block[static_cast<std::size_t>(l)]);
                for (std::size_t t = 0; t < part.size(); ++t) yb[static_cast<std::size_t>(i)][t] += part[t];
            }
        y.push_back(std::move(yb));
    }
    return y;
}

// Discarded periods so that the slowest pole's transient has decayed below
// 1e-16 of its start: r^(D N) <= 1e-16, r the largest pole radius.
inline int transient_periods_for(const MimoCase& c) {
    const double n = c.j["period_samples"].get<double>();
    return static_cast<int>(std::ceil(std::log(1e-16) / (n * std::log(c.pole_radius))));
}

}  // namespace piezoloop::test
