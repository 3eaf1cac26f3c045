// Mixed-sensitivity H∞ design for a SISO plant: the controller K that
// minimises
//       || [ W1 S ; W2 K S ; W3 T ] ||∞,   S = 1 / (1 + G K), T = G K S,
// with u = K e, e = r - y (negative feedback from the user's side).
//
// Augmented plant (the convention of MATLAB's augw and Octave's mixsyn):
//   inputs [w; u], outputs [z1; z2; z3; e]:
//   z1 = W1 e,  z2 = W2 u,  z3 = W3 G u,  e = w - G u,
// with the states of G, W1, W2, W3 stacked in that order, each member
// realised from its factored form (lti/zpk2ss: no polynomial of degree > 2
// multiplied out, which is what makes Ahmad2020's G(s) with coefficients
// spanning 1e0 … 1e23 usable). The H∞ problem is then hinfsyn's (its state
// balancing and frequency scaling apply) with u = K e.
//
// Weights must be proper and stable (their poles are closed-loop poles of
// the augmented plant that no controller can move); an omitted W2 or W3
// drops its output. Without W2, D12 = -W1(∞) G(∞) is zero for a strictly
// proper G and hinfsyn reports "D12 not of full column rank".
//
// The returned figures are recomputed from the controller: hinf_W1S etc.
// with analysis/hinf.hpp (SISO, certified), gamma with the MIMO norm of the
// stacked closed loop.
#pragma once

#include <optional>
#include <string>

#include "lti/lti.hpp"
#include "synth/hinfsyn.hpp"

namespace piezoloop::design {

struct MixsynResult {
    HinfSynthesis synthesis;  // the H∞ problem's result (gamma_opt, diagnostics)
    Ss controller;            // SISO, e -> u
    Zpk controller_zpk;
    double gamma = 0.0;       // ||[W1 S; W2 K S; W3 T]||∞ of the returned controller
    bool stable = false;      // closed loop of G and K
    double hinf_W1S = 0.0, hinf_W2KS = 0.0, hinf_W3T = 0.0;  // 0 for an omitted weight
    int order = 0;            // controller states
    int plant_order = 0;      // augmented plant states
};

// Throws std::invalid_argument naming the weight ("w2: weight is unstable
// (pole at 3 + 0j rad/s)", "w3: weight is improper (2 zeros > 1 poles)",
// "plant: ...") and SynthesisError when the H∞ problem has no solution.
MixsynResult mixsyn(const Zpk& g, const Zpk& w1, const std::optional<Zpk>& w2, const std::optional<Zpk>& w3,
                    const HinfOptions& options = {});

// A weight (or, must_be_stable = false, a plant) checked as mixsyn does —
// continuous, proper, finite non-zero gain, stable poles — and realised by
// zpk2ss; the messages start with `name` (also used by design musyn).
Ss checked_weight(const Zpk& m, const std::string& name, bool must_be_stable);

// The augmented plant alone (checks as above).
GeneralisedPlant augment(const Zpk& g, const Zpk& w1, const std::optional<Zpk>& w2, const std::optional<Zpk>& w3);

}  // namespace piezoloop::design
