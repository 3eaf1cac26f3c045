// Continuous -> discrete (docs/models.md, 'Biquad cascades'), on the factored form so that nothing of
// high order is multiplied out:
//
//  * Tustin (bilinear), optionally pre-warped at w_p: s = K (z - 1)/(z + 1)
//    with K = 2/Ts, or K = w_p / tan(w_p Ts / 2) so that the response at
//    w_p is exactly the continuous one. Each root maps as
//    z = (K + r)/(K - r); the relative degree becomes zeros at z = -1;
//    gain k prod(K - z_i) / prod(K - p_i). (scipy.signal.bilinear_zpk.)
//  * Zero-order hold (step invariant): state space of the cascade, then
//    expm([A B; 0 0] Ts) = [Phi Gamma; 0 I] (Eigen's MatrixFunctions,
//    scaling and squaring Padé), back to zpk with ss2zpk. The poles are
//    replaced by the exact images e^{p Ts} of the continuous ones (what ZOH
//    does to poles), so only zeros and gain come from the matrix route.
//    (scipy.signal.cont2discrete, method 'zoh'.)
//  * Matched pole-zero: poles and finite zeros map as e^{r Ts}; each zero
//    at infinity becomes a zero at z = -1 (Franklin & Powell), so the
//    result is proper with the continuous relative degree spent at
//    Nyquist; the gain matches the DC gain, or the magnitude at w = 1e-3
//    Nyquist when there is a pole or zero at s = 0.
//
// Errors (std::invalid_argument): the model is already discrete, improper,
// ts <= 0, pre-warp at or above Nyquist, a pole at s = K (Tustin).
#pragma once

#include <string>

#include "lti/lti.hpp"

namespace piezoloop::design {

enum class C2dMethod { kTustin, kZoh, kMatched };

// "tustin" | "zoh" | "matched" (throws for anything else) and back.
C2dMethod parse_c2d_method(const std::string& name);
const char* c2d_method_name(C2dMethod m);

Zpk tustin(const Zpk& continuous, double ts, double prewarp_rad_s = 0.0);
Zpk zoh(const Zpk& continuous, double ts);
Ss zoh(const Ss& continuous, double ts);
Zpk matched(const Zpk& continuous, double ts);

// Dispatch; prewarp applies to Tustin only (0: none).
Zpk c2d(const Zpk& continuous, double ts, C2dMethod method, double prewarp_rad_s = 0.0);

}  // namespace piezoloop::design
