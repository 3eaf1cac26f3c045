#include "synth/damping_mixsyn.hpp"

#include "lti/lti_convert.hpp"
#include "synth/mixsyn.hpp"

namespace piezoloop::design {

using Eigen::Index;
using Eigen::MatrixXd;

GeneralisedPlant augment_input_disturbance(const Zpk& g, const Zpk& w1, const Zpk& w2, const Zpk& wd) {
    const Ss G = checked_weight(g, "plant", false);
    const Ss W1 = checked_weight(w1, "w1", true);
    const Ss W2 = checked_weight(w2, "w2", true);
    const Ss Wd = checked_weight(wd, "wd", true);
    const Index ng = G.A.rows(), n1 = W1.A.rows(), n2 = W2.A.rows(), nd = Wd.A.rows();
    const Index o1 = ng, o2 = ng + n1, od = ng + n1 + n2;  // state offsets
    const Index n = od + nd;
    enum : Index { kW = 0, kD = 1, kU = 2 };      // input columns
    enum : Index { kZ1 = 0, kZ2 = 1, kE = 2 };    // output rows
    GeneralisedPlant p;
    p.n_w = 2;
    p.n_u = 1;
    p.n_z = 2;
    p.n_y = 1;
    StateSpace& s = p.sys;
    s.A = MatrixXd::Zero(n, n);
    s.B = MatrixXd::Zero(n, 3);
    s.C = MatrixXd::Zero(3, n);
    s.D = MatrixXd::Zero(3, 3);
    // The plant's input v = u + Wd d, Wd d = Cd xd + Dd d; xd' = Ad xd + Bd d.
    s.A.block(od, od, nd, nd) = Wd.A;
    s.B.block(od, kD, nd, 1) = Wd.B;
    // G: xg' = Ag xg + Bg v, yg = Cg xg + Dg v.
    s.A.block(0, 0, ng, ng) = G.A;
    s.A.block(0, od, ng, nd) = G.B * Wd.C;
    s.B.block(0, kD, ng, 1) = G.B * Wd.D;
    s.B.block(0, kU, ng, 1) = G.B;
    // e = w - yg: one row (the measured output), as a row vector over the
    // states and the inputs, reused by W1.
    Eigen::RowVectorXd e_x = Eigen::RowVectorXd::Zero(n);
    e_x.segment(0, ng) = -G.C;
    e_x.segment(od, nd) = -G.D * Wd.C;
    Eigen::RowVector3d e_in(1.0, -G.D * Wd.D, -G.D);
    s.C.row(kE) = e_x;
    s.D.row(kE) = e_in;
    // W1 on e: x1' = A1 x1 + B1 e; z1 = C1 x1 + D1 e.
    s.A.block(o1, o1, n1, n1) = W1.A;
    s.A.block(o1, 0, n1, n) += W1.B * e_x;
    s.B.block(o1, 0, n1, 3) = W1.B * e_in;
    s.C.row(kZ1) = W1.D * e_x;
    s.C.block(kZ1, o1, 1, n1) = W1.C;
    s.D.row(kZ1) = W1.D * e_in;
    // W2 on u.
    s.A.block(o2, o2, n2, n2) = W2.A;
    s.B.block(o2, kU, n2, 1) = W2.B;
    s.C.block(kZ2, o2, 1, n2) = W2.C;
    s.D(kZ2, kU) = W2.D;
    return p;
}

DampingMixsynResult damping_mixsyn(const Zpk& g, const Zpk& w1, const Zpk& w2, const Zpk& wd,
                                   const HinfOptions& options) {
    const GeneralisedPlant p = augment_input_disturbance(g, w1, w2, wd);
    DampingMixsynResult r;
    r.synthesis = hinfsyn(p, options);
    r.controller = to_siso(r.synthesis.controller);
    r.controller_zpk = ss2zpk(r.controller);
    r.order = static_cast<int>(r.synthesis.controller.states());
    r.stable = r.synthesis.stable;
    r.gamma = r.synthesis.gamma;
    return r;
}

}  // namespace piezoloop::design
