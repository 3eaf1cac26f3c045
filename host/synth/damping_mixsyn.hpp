// Mixed-sensitivity H∞ design that damps the plant's lightly damped modes
// instead of cancelling them: the controller K that minimises
//
//       || [ W1 S     W1 S G Wd ] ||
//       || [ W2 K S   W2 T Wd   ] ||∞ ,   S = 1 / (1 + G K), T = G K S,
//
// with u = K e, e = r - y, and a disturbance d entering at the plant's
// input through Wd. A plain S / KS design (synth/mixsyn) puts the
// controller's zeros on a lightly damped pole pair of G: the pair then
// drops out of S and K S and stays in the closed loop at its open-loop
// damping, so a step or a saturation leaves the mode ringing for ln(1/tol)
// / (ζ ω_n) (a 596 Hz mode at ζ 0.007 needs 0.26 s to fall to 0.1 %). The
// input disturbance's response S G keeps the pair (K cannot cancel a pole
// of G there), and at the mode |G| is 1/(2ζ) times its background: a
// controller that leaves the mode undamped pays that peak in the norm, so
// the optimum moves the pair's closed-loop poles to the left. This is the
// input-disturbance (four-block) form of H∞ loop design used for
// nanopositioners whose first resonance limits the bandwidth (Sebastian &
// Salapaka, "Design methodologies for robust nano-positioning", IEEE TCST
// 13(6), 2005; Fleming & Leang, "Design, Modeling and Control of
// Nanopositioning Systems", Springer 2014, ch. 9: a damped resonance lets
// the tracking loop's bandwidth rise from about 2 ζ ω_n to a fraction of
// ω_n).
//
// Augmented plant: inputs [w; d; u], outputs [z1; z2; e]:
//   z1 = W1 e,  z2 = W2 u,  e = w - G (u + Wd d),
// with the states of G, W1, W2, Wd stacked in that order, each realised as
// mixsyn realises it (lti/zpk2ss). The problem is hinfsyn's.
#pragma once

#include "lti/lti.hpp"
#include "synth/hinfsyn.hpp"

namespace piezoloop::design {

struct DampingMixsynResult {
    HinfSynthesis synthesis;
    Ss controller;            // SISO, e -> u
    Zpk controller_zpk;
    double gamma = 0.0;       // the achieved norm of the 2 x 2 closed loop
    bool stable = false;
    int order = 0;            // controller states
};

// The augmented plant alone. Weights must be continuous, proper, stable and
// of finite non-zero gain (std::invalid_argument naming "plant", "w1", "w2"
// or "wd", as mixsyn's checked_weight says).
GeneralisedPlant augment_input_disturbance(const Zpk& g, const Zpk& w1, const Zpk& w2, const Zpk& wd);

// Throws as augment_input_disturbance and SynthesisError when the H∞
// problem has no solution.
DampingMixsynResult damping_mixsyn(const Zpk& g, const Zpk& w1, const Zpk& w2, const Zpk& wd,
                                   const HinfOptions& options = {});

}  // namespace piezoloop::design
