#include "synth/dk_iteration.hpp"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <limits>
#include <stdexcept>

#include "lti/lti_convert.hpp"
#include "synth/d_fit.hpp"
#include "synth/mixsyn.hpp"

namespace piezoloop::design {
namespace {

using Eigen::Index;
using Eigen::MatrixXd;

// A signal of the generalised plant as a linear map of [states; inputs].
struct Signal {
    Eigen::RowVectorXd c;  // over the plant's states
    Eigen::RowVectorXd d;  // over the plant's inputs
};

}  // namespace

GeneralisedPlant musyn_plant(const MusynProblem& pb) {
    const Ss G = checked_weight(pb.plant, "plant", false);
    const Ss Hm = checked_weight(pb.hm, "hm", true);
    const Ss W1 = checked_weight(pb.w1, "w1", true);
    const Ss W3 = pb.w3 ? checked_weight(*pb.w3, "w3", true) : Ss{};
    const Ss W2 = pb.w2 ? checked_weight(*pb.w2, "w2", true) : Ss{};
    const Index ng = G.A.rows(), nm = Hm.A.rows(), n1 = W1.A.rows();
    const Index n3 = pb.w3 ? W3.A.rows() : 0, n2 = pb.w2 ? W2.A.rows() : 0;
    const Index n = ng + nm + n1 + n3 + n2;
    const Index p = 1 + (pb.w3 ? 1 : 0) + (pb.w2 ? 1 : 0);  // performance outputs
    constexpr Index kWd = 0, kR = 1, kU = 2;                  // input columns
    GeneralisedPlant gp;
    gp.n_w = 2;
    gp.n_u = 1;
    gp.n_z = static_cast<int>(1 + p);
    gp.n_y = 1;
    StateSpace& s = gp.sys;
    s.A = MatrixXd::Zero(n, n);
    s.B = MatrixXd::Zero(n, 3);
    s.C = MatrixXd::Zero(p + 2, n);
    s.D = MatrixXd::Zero(p + 2, 3);
    auto input = [&](Index col) {
        Signal x{Eigen::RowVectorXd::Zero(n), Eigen::RowVectorXd::Zero(3)};
        x.d(col) = 1.0;
        return x;
    };
    // A weight W with states at `off`, driven by `in`, written to output row `row`.
    auto add_weight = [&](const Ss& w, Index off, const Signal& in, Index row) {
        const Index nw = w.A.rows();
        s.A.block(off, off, nw, nw) = w.A;
        s.A.middleRows(off, nw) += w.B * in.c;
        s.B.middleRows(off, nw) += w.B * in.d;
        s.C.row(row) = w.D * in.c;
        s.C.block(row, off, 1, nw) += w.C;
        s.D.row(row) = w.D * in.d;
    };
    // G driven by u + w_Δ.
    Signal gin = input(kU);
    gin.d(kWd) = 1.0;
    s.A.topLeftCorner(ng, ng) = G.A;
    s.B.topRows(ng) = G.B * gin.d;
    Signal y{Eigen::RowVectorXd::Zero(n), G.D * gin.d};
    y.c.head(ng) = G.C;
    Signal e{-y.c, input(kR).d - y.d};
    Index off = ng;
    add_weight(Hm, off, input(kU), 0);  // z_Δ = H_m u
    off += nm;
    add_weight(W1, off, e, 1);          // z_e = W1 e
    off += n1;
    Index row = 2;
    if (pb.w3) {
        add_weight(W3, off, y, row++);  // z_y = W3 y
        off += n3;
    }
    if (pb.w2) add_weight(W2, off, input(kU), row++);  // z_u = W2 u
    s.C.row(row) = e.c;                 // the measurement e
    s.D.row(row) = e.d;
    check_plant(gp, "musyn plant");
    return gp;
}

GeneralisedPlant scale_plant(const GeneralisedPlant& p, const Zpk& d) {
    if (is_discrete(d.ts)) throw std::invalid_argument("d scaling: must be continuous");
    if (d.zeros.size() != d.poles.size()) throw std::invalid_argument("d scaling: must be biproper");
    for (const cplx& z : d.zeros)
        if (!(z.real() < 0.0)) throw std::invalid_argument("d scaling: must be minimum phase");
    for (const cplx& q : d.poles)
        if (!(q.real() < 0.0)) throw std::invalid_argument("d scaling: must be stable");
    if (!(d.gain > 0.0) || !std::isfinite(d.gain)) throw std::invalid_argument("d scaling: gain must be > 0");
    Zpk dinv{d.poles, d.zeros, 1.0 / d.gain, 0.0};
    const Ss D = zpk2ss(d), Di = zpk2ss(dinv);
    const StateSpace& s = p.sys;
    const Index n = s.states(), k = D.A.rows(), ki = Di.A.rows();
    const Index ni = s.inputs(), no = s.outputs();
    // States [x_P; x_d (output scaling); x_i (input scaling)].
    // Input 0 becomes v = Di(w~): x_i' = Ai x_i + Bi w~, v = Ci x_i + Di w~.
    // Output 0 becomes D(z0): x_d' = Ad x_d + Bd z0, z~0 = Cd x_d + Dd z0.
    StateSpace r;
    r.A = MatrixXd::Zero(n + k + ki, n + k + ki);
    r.B = MatrixXd::Zero(n + k + ki, ni);
    r.C = MatrixXd::Zero(no, n + k + ki);
    r.D = s.D;
    // P with its first input fed by v.
    r.A.topLeftCorner(n, n) = s.A;
    r.A.block(0, n + k, n, ki) = s.B.col(0) * Di.C;
    r.B.topRows(n) = s.B;
    r.B.block(0, 0, n, 1) = s.B.col(0) * Di.D;
    r.C.leftCols(n) = s.C;
    r.C.block(0, n + k, no, ki) = s.D.col(0) * Di.C;
    r.D.col(0) = s.D.col(0) * Di.D;
    r.A.block(n + k, n + k, ki, ki) = Di.A;
    r.B.block(n + k, 0, ki, 1) = Di.B;
    // z0 as a map of the new states and inputs (row 0 of the above).
    const Eigen::RowVectorXd z0c = r.C.row(0), z0d = r.D.row(0);
    r.A.block(n, n, k, k) = D.A;
    r.A.middleRows(n, k) += D.B * z0c;
    r.B.middleRows(n, k) += D.B * z0d;
    r.C.row(0) = D.D * z0c;
    r.C.block(0, n, 1, k) += D.C;
    r.D.row(0) = D.D * z0d;
    GeneralisedPlant q = p;
    q.sys = r;
    return q;
}

std::vector<double> musyn_grid(const GeneralisedPlant& p, int points_per_decade) {
    double lo = std::numeric_limits<double>::infinity(), hi = 0.0;
    const Eigen::VectorXcd ev = p.sys.A.eigenvalues();
    for (Index i = 0; i < ev.size(); ++i) {
        const double m = std::abs(ev(i));
        if (m < 1e-9) continue;  // integrators: start a few decades below the rest
        lo = std::min(lo, m);
        hi = std::max(hi, m);
    }
    if (!(hi > 0.0)) lo = hi = 1.0;
    const double a = std::log10(lo) - 1.0, b = std::log10(hi) + 1.0;
    const int n = std::max(2, static_cast<int>(std::ceil((b - a) * points_per_decade)) + 1);
    std::vector<double> g(static_cast<std::size_t>(n));
    for (int i = 0; i < n; ++i) g[static_cast<std::size_t>(i)] = std::pow(10.0, a + (b - a) * i / (n - 1));
    return g;
}

MuSweep mu_sweep(const GeneralisedPlant& p, const StateSpace& k, const std::vector<double>& grid) {
    MuSweep r;
    const StateSpace cl = balance_states(lft_lower(p.sys, k));
    r.stable = is_stable(cl);
    const int np = p.n_z - 1;
    std::vector<double> d_prev;
    for (double w : grid) {
        const Eigen::MatrixXcd m = evaluate(cl, {0.0, w});
        double mu = std::numeric_limits<double>::infinity(), d = 1.0;
        if (m.allFinite()) {
            const MuBound b = mu_bounds(m, {{1, 1}, {np, 1}}, d_prev);
            mu = b.upper;
            d = b.d[0];
            d_prev = b.d;
        }
        r.w_rad_s.push_back(w);
        r.mu.push_back(mu);
        r.d.push_back(d);
        if (mu > r.peak || r.mu.size() == 1) {
            r.peak = mu;
            r.peak_w_rad_s = w;
        }
    }
    if (!r.stable) r.peak = std::numeric_limits<double>::infinity();
    return r;
}

MusynResult musyn(const MusynProblem& pb, const MusynOptions& o) {
    if (o.iterations < 1) throw std::invalid_argument("iterations: must be >= 1");
    if (o.d_order < 0 || o.d_order > 12) throw std::invalid_argument("d-order: must be in [0, 12]");
    if (!(o.min_improvement >= 0.0)) throw std::invalid_argument("min improvement: must be >= 0");
    const GeneralisedPlant plant = musyn_plant(pb);
    const std::vector<double> grid = musyn_grid(plant, o.points_per_decade);
    MusynResult r;
    r.plant_order = static_cast<int>(plant.sys.states());
    std::optional<Zpk> d;  // none: d = 1
    std::vector<HinfSynthesis> ks;
    using clock = std::chrono::steady_clock;
    for (int it = 1; it <= o.iterations; ++it) {
        const auto t0 = clock::now();
        const GeneralisedPlant scaled = d ? scale_plant(plant, *d) : plant;
        HinfSynthesis syn;
        try {
            syn = hinfsyn(scaled, o.hinf);
        } catch (const SynthesisError& e) {
            if (it == 1) throw;
            r.stop_reason = "K step " + std::to_string(it) + " failed: " + e.what();
            break;
        }
        const MuSweep sw = mu_sweep(plant, syn.controller, grid);
        DkRecord rec;
        rec.iteration = it;
        rec.gamma = syn.gamma;
        rec.mu_peak = sw.peak;
        rec.mu_peak_w_rad_s = sw.peak_w_rad_s;
        rec.controller_order = static_cast<int>(syn.controller.states());
        rec.plant_order = static_cast<int>(scaled.sys.states());
        rec.d_used = d ? *d : Zpk{{}, {}, 1.0, 0.0};
        ks.push_back(std::move(syn));
        const bool last = it == o.iterations;
        const bool stalled = it > 1 && !(rec.mu_peak < r.records.back().mu_peak * (1.0 - o.min_improvement));
        if (!last && !stalled && std::isfinite(sw.peak)) {
            // D step: fit |d_Δ|, weighted by μ / μ_peak.
            std::vector<double> wt(sw.mu.size()), dm(sw.d.size());
            for (std::size_t i = 0; i < sw.mu.size(); ++i) {
                wt[i] = std::isfinite(sw.mu[i]) ? sw.mu[i] / sw.peak : 0.0;
                dm[i] = std::clamp(sw.d[i], 1e-8, 1e8);
            }
            const DFit fit = fit_d_scaling(sw.w_rad_s, dm, wt, o.d_order);
            rec.d_fit_max_rel_error = fit.max_rel_error;
            d = fit.d;
        }
        rec.seconds = std::chrono::duration<double>(clock::now() - t0).count();
        r.records.push_back(rec);
        if (o.on_iteration) o.on_iteration(rec);
        if (!std::isfinite(sw.peak)) {
            r.stop_reason = "closed loop of iteration " + std::to_string(it) + " not stable";
            break;
        }
        if (stalled) {
            r.stop_reason = "mu fell by less than " + std::to_string(o.min_improvement * 100.0) + " %";
            break;
        }
        if (last) r.stop_reason = "iteration limit";
    }
    for (std::size_t i = 1; i < r.records.size(); ++i)
        if (r.records[i].mu_peak < r.records[static_cast<std::size_t>(r.best)].mu_peak) r.best = static_cast<int>(i);
    const HinfSynthesis& k = ks[static_cast<std::size_t>(r.best)];
    r.controller = k.controller;
    r.controller_siso = to_siso(k.controller);
    r.controller_zpk = ss2zpk(r.controller_siso);
    r.gamma = k.gamma;
    r.stable = r.records[static_cast<std::size_t>(r.best)].mu_peak < std::numeric_limits<double>::infinity() &&
               is_stable(lft_lower(plant.sys, k.controller));
    r.order = static_cast<int>(k.controller.states());
    return r;
}

}  // namespace piezoloop::design
