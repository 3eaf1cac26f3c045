#include "synth/mixsyn.hpp"

#include <cmath>
#include <stdexcept>

#include "analysis/hinf.hpp"
#include "lti/lti_convert.hpp"
#include "synth/mimo_hinf.hpp"
#include "format/number.hpp"

namespace piezoloop::design {
namespace {

using Eigen::Index;
using Eigen::MatrixXd;

}  // namespace

Ss checked_weight(const Zpk& m, const std::string& name, bool must_be_stable) {
    if (is_discrete(m.ts)) throw std::invalid_argument(name + ": must be continuous (no ts)");
    if (m.zeros.size() > m.poles.size())
        throw std::invalid_argument(name + ": weight is improper (" + std::to_string(m.zeros.size()) + " zeros > " +
                                    std::to_string(m.poles.size()) +
                                    " poles); add far poles, e.g. (1 + s/wz) / (1 + s/wp) with wp >> wz");
    if (!(std::isfinite(m.gain)) || m.gain == 0.0) throw std::invalid_argument(name + ": gain must be finite and non-zero");
    if (must_be_stable)
        for (const cplx& p : m.poles)
            if (!(p.real() < 0.0))
                throw std::invalid_argument(name + ": weight is unstable (pole at " + format::complex_significant(p, 4) +
                                            " rad/s); weights must be stable: move an integrator to -eps");
    return zpk2ss(m);
}


GeneralisedPlant augment(const Zpk& g, const Zpk& w1, const std::optional<Zpk>& w2, const std::optional<Zpk>& w3) {
    const Ss G = checked_weight(g, "plant", false);
    const Ss W1 = checked_weight(w1, "w1", true);
    const Ss W2 = w2 ? checked_weight(*w2, "w2", true) : Ss{};
    const Ss W3 = w3 ? checked_weight(*w3, "w3", true) : Ss{};
    const Index ng = G.A.rows(), n1 = W1.A.rows(), n2 = w2 ? W2.A.rows() : 0, n3 = w3 ? W3.A.rows() : 0;
    const Index n = ng + n1 + n2 + n3;
    const Index nz = 1 + (w2 ? 1 : 0) + (w3 ? 1 : 0);
    const Index o1 = ng, o2 = ng + n1, o3 = ng + n1 + n2;  // state offsets
    GeneralisedPlant p;
    p.n_w = 1;
    p.n_u = 1;
    p.n_z = static_cast<int>(nz);
    p.n_y = 1;
    StateSpace& s = p.sys;
    s.A = MatrixXd::Zero(n, n);
    s.B = MatrixXd::Zero(n, 2);
    s.C = MatrixXd::Zero(nz + 1, n);
    s.D = MatrixXd::Zero(nz + 1, 2);
    // G: xg' = Ag xg + Bg u, yg = Cg xg + Dg u.
    s.A.block(0, 0, ng, ng) = G.A;
    s.B.block(0, 1, ng, 1) = G.B;
    // e = w - yg.
    const Index ie = nz;
    s.C.block(ie, 0, 1, ng) = -G.C;
    s.D(ie, 0) = 1.0;
    s.D(ie, 1) = -G.D;
    // W1 on e: x1' = A1 x1 + B1 e; z1 = C1 x1 + D1 e.
    s.A.block(o1, o1, n1, n1) = W1.A;
    s.A.block(o1, 0, n1, ng) = -W1.B * G.C;
    s.B.block(o1, 0, n1, 1) = W1.B;
    s.B.block(o1, 1, n1, 1) = -W1.B * G.D;
    s.C.block(0, o1, 1, n1) = W1.C;
    s.C.block(0, 0, 1, ng) = -W1.D * G.C;
    s.D(0, 0) = W1.D;
    s.D(0, 1) = -W1.D * G.D;
    Index row = 1;
    if (w2) {  // W2 on u
        s.A.block(o2, o2, n2, n2) = W2.A;
        s.B.block(o2, 1, n2, 1) = W2.B;
        s.C.block(row, o2, 1, n2) = W2.C;
        s.D(row, 1) = W2.D;
        ++row;
    }
    if (w3) {  // W3 on yg
        s.A.block(o3, o3, n3, n3) = W3.A;
        s.A.block(o3, 0, n3, ng) = W3.B * G.C;
        s.B.block(o3, 1, n3, 1) = W3.B * G.D;
        s.C.block(row, o3, 1, n3) = W3.C;
        s.C.block(row, 0, 1, ng) = W3.D * G.C;
        s.D(row, 1) = W3.D * G.D;
    }
    return p;
}

MixsynResult mixsyn(const Zpk& g, const Zpk& w1, const std::optional<Zpk>& w2, const std::optional<Zpk>& w3,
                    const HinfOptions& options) {
    const GeneralisedPlant p = augment(g, w1, w2, w3);
    MixsynResult r;
    r.plant_order = static_cast<int>(p.sys.states());
    r.synthesis = hinfsyn(p, options);
    const StateSpace& k = r.synthesis.controller;
    r.controller = to_siso(k);
    r.order = static_cast<int>(k.states());
    r.controller_zpk = ss2zpk(r.controller);
    r.stable = r.synthesis.stable;
    r.gamma = r.synthesis.gamma;
    // Each channel of the closed loop (from w to z_i) with the analysis code.
    const StateSpace& cl = r.synthesis.closed_loop;
    Index row = 0;
    r.hinf_W1S = hinf_norm(to_siso(cl, row++, 0)).norm;
    if (w2) r.hinf_W2KS = hinf_norm(to_siso(cl, row++, 0)).norm;
    if (w3) r.hinf_W3T = hinf_norm(to_siso(cl, row++, 0)).norm;
    return r;
}

}  // namespace piezoloop::design
