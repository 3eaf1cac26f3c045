#!/usr/bin/python3
"""Reference for host/lti/lti_convert and freqresp on the sources' models.

Each model is a product of small factors with the published coefficients
(docs/models.md). For each one this writes
  * the exact roots of every factor's polynomials and the multiplied-out
    transfer function, computed with mpmath at 60 digits (independent of any
    double-precision algorithm), rounded to double;
  * scipy.signal.tf2zpk of the multiplied-out tf (numpy.roots: companion
    matrix eigenvalues in double), for comparison;
  * the frequency response at a log grid, evaluated exactly (mpmath, on the
    factored form), and scipy.signal.freqs_zpk for comparison.
Run with Debian's /usr/bin/python3; writes tests/golden/design_convert.json.
"""
import json
import os

import mpmath as mp
import numpy as np
from scipy import signal

mp.mp.dps = 60

# name -> (list of (gain, num, den) factors in descending powers, ts)
# Ahmad2020 H_m parameters (Ahmad2020)
g_m, z1, z2, z3, z4, w1, w2, w3, M_m, eps_m = 0.02, 3.5, 0.05, 0.7, 0.08, 6.3e3, 1.4e4, 1e4, 1.0, 1e-8
Me, eps_e, we = 2.0, 0.003, 1.26e3
My, eps_y, wy = 1.5, 1e-4, 7.5e3

MODELS = {
    "ahmad2020_K": ([(1.0, [5.29e6, 1.78e10, 1.04e15, 7.66e17, 1.51e22, 4.73e22],
                      [1.0, 4.69e5, 3.21e10, 7.86e14, 7.38e18, 4.71e19, 7.79e19])], 0.0),
    "ahmad2020_G": ([(1.0, [2.01e11, 4.74e15, 2.76e19, 1.84e23],
                      [1.0, 1.08e4, 2.95e8, 1.98e12, 1.65e16, 5.79e19, 2.05e23])], 0.0),
    "janaideh2016_D": ([(-20.7, [1.0, -1.22e5], [1.0]), (1.0, [1.0, 2.99e4], [1.0]),
                        (1.0, [1.0, -2.776e4], [1.0]), (1.0, [1.0, -1.07e4], [1.0]),
                        (1.0, [1.0, 1430.0], [1.0]), (1.0, [1.0, 4.3e4, 3.2e9], [1.0]),
                        (1.0, [1.0], [1.0, 925.0, 4.59e5]), (1.0, [1.0], [1.0, 55.0, 1.4e7]),
                        (1.0, [1.0], [1.0, 1.54e4, 4e9]), (1.0, [1.0], [1.0, 964.0, 3.95e9])], 0.0),
    "janaideh2016_C": ([(0.016, [1.0, 7.9e6], [1.0, 8.8e4]), (1.0, [1.0, 971.0, 4.6e5], [1.0, 974.0]),
                        (1.0, [1.0, 43.0, 1.4e7], [1.0, 1.0]), (1.0, [1.0], [1.0, 1153.0, 1.6e7])], 0.0),
    "ahmad2020_Hm": ([(g_m, [1.0, 2 * z1 * w1, w1 * w1], [1.0, 2 * z2 * w1, w1 * w1]),
                      (1.0, [1.0, 2 * z3 * w2, w2 * w2], [1.0, 2 * z4 * w2, w2 * w2]),
                      (1.0, [eps_m, w3], [1.0, w3 / M_m])], 0.0),
    "ahmad2020_He": ([(1.0, [1.0 / Me, we], [1.0, we * eps_e])], 0.0),
    "ahmad2020_Hy": ([(1.0, [1.0, wy / My], [eps_y, wy]), (1.0, [1.0, wy / My], [eps_y, wy])], 0.0),
    "shan2012_Q": ([(1.0, [0.3558], [1.0, -0.6442])], 1e-5),
    "shan2012_PI": ([(1.0, [1.3 + 40000.0 * 1e-5, -1.3], [1.0, -1.0])], 1e-5),
}


def mp_roots(p):
    p = [mp.mpf(c) for c in p]
    while p and p[0] == 0:
        p = p[1:]
    if len(p) <= 1:
        return []
    return mp.polyroots(p, maxsteps=500, extraprec=200)


def mp_mul(a, b):
    out = [mp.mpf(0)] * (len(a) + len(b) - 1)
    for i, x in enumerate(a):
        for j, y in enumerate(b):
            out[i + j] += x * y
    return out


def pairs(roots):
    # Sorted by magnitude, then real, then |imag|, +imag first: the order of
    # piezoloop::design::canonical_roots.
    rs = sorted(roots, key=lambda r: (float(abs(r)), float(mp.re(r)), float(abs(mp.im(r))), -float(mp.im(r))))
    return [[float(mp.re(r)), float(mp.im(r))] for r in rs]


def cplx_list(v):
    return [[float(np.real(x)), float(np.imag(x))] for x in v]


def main():
    w = [float(x) for x in np.logspace(-1, 7, 33)]
    out = {"w_rad_s": w, "models": []}
    for name, (factors, ts) in MODELS.items():
        gain = mp.mpf(1)
        zeros, poles = [], []
        num, den = [mp.mpf(1)], [mp.mpf(1)]
        for g, n, d in factors:
            n_mp = [mp.mpf(c) for c in n]
            d_mp = [mp.mpf(c) for c in d]
            gain *= mp.mpf(g) * n_mp[0] / d_mp[0]
            zeros += list(mp_roots(n))
            poles += list(mp_roots(d))
            num = mp_mul(num, [mp.mpf(g) * c for c in n_mp])
            den = mp_mul(den, d_mp)
        # Exact response on the factored form.
        h = []
        for wi in w:
            x = mp.expj(mp.mpf(wi) * ts) if ts > 0 else mp.mpc(0, wi)
            v = mp.mpc(1)
            for g, n, d in factors:
                v *= mp.mpf(g) * mp.polyval([mp.mpf(c) for c in n], x) / mp.polyval([mp.mpf(c) for c in d], x)
            h.append([float(mp.re(v)), float(mp.im(v))])
        num_f = [float(c) for c in num]
        den_f = [float(c) for c in den]
        z_s, p_s, k_s = signal.tf2zpk(num_f, den_f)
        if ts > 0:
            _, h_s = signal.freqz_zpk(z_s, p_s, k_s, worN=np.asarray(w) * ts)
        else:
            _, h_s = signal.freqs_zpk(z_s, p_s, k_s, worN=np.asarray(w))
        out["models"].append({
            "name": name, "ts": ts,
            "factors": [{"gain": g, "num": n, "den": d} for g, n, d in factors],
            "num": num_f, "den": den_f,
            "zeros": pairs(zeros), "poles": pairs(poles), "gain": float(gain),
            "h": h,
            "scipy_zeros": cplx_list(z_s), "scipy_poles": cplx_list(p_s), "scipy_gain": float(k_s),
            "scipy_h": cplx_list(h_s),
        })
    path = os.path.join(os.path.dirname(__file__), "..", "..", "tests", "golden", "design_convert.json")
    with open(path, "w") as f:
        json.dump(out, f, indent=1)
        f.write("\n")


if __name__ == "__main__":
    main()
