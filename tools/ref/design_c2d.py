#!/usr/bin/python3
"""Reference for host/lti/c2d (Tustin, ZOH, matched) on the sources' models.

For each case this writes the exact frequency response of the discretised
model at 25 frequencies up to Nyquist, computed with mpmath (60 digits) from
the exact roots of the published factors:
  * tustin:  H_d(z) = H_c(K (z - 1) / (z + 1)), K = 2 / Ts, or with pre-warp
             at w_p: K = w_p / tan(w_p Ts / 2);
  * zoh:     H_d(z) = H(0) + sum_i r_i (z - 1) / (z - e^{p_i Ts}), r_i the
             residues of H(s) / s at the (simple) poles p_i (step invariance);
  * matched: zeros and poles e^{r Ts}, the relative degree as zeros at
             z = -1, gain matched at DC (the convention of c2d.hpp).
and, for comparison, scipy: signal.bilinear_zpk (tustin, on the exact roots
rounded to double) and signal.cont2discrete(..., 'zoh') for the 1st/2nd
order cases (its tf -> ss route is fine at that order).
Run with Debian's /usr/bin/python3; writes tests/golden/design_c2d.json.
"""
import json
import os

import mpmath as mp
import numpy as np
from scipy import signal

mp.mp.dps = 60

MODELS = {
    "ahmad2020_K": [(1.0, [5.29e6, 1.78e10, 1.04e15, 7.66e17, 1.51e22, 4.73e22],
                     [1.0, 4.69e5, 3.21e10, 7.86e14, 7.38e18, 4.71e19, 7.79e19])],
    "ahmad2020_G": [(1.0, [2.01e11, 4.74e15, 2.76e19, 1.84e23],
                     [1.0, 1.08e4, 2.95e8, 1.98e12, 1.65e16, 5.79e19, 2.05e23])],
    "janaideh2016_C": [(0.016, [1.0, 7.9e6], [1.0, 8.8e4]), (1.0, [1.0, 971.0, 4.6e5], [1.0, 974.0]),
                       (1.0, [1.0, 43.0, 1.4e7], [1.0, 1.0]), (1.0, [1.0], [1.0, 1153.0, 1.6e7])],
    "janaideh2016_D": [(-20.7, [1.0, -1.22e5], [1.0]), (1.0, [1.0, 2.99e4], [1.0]),
                       (1.0, [1.0, -2.776e4], [1.0]), (1.0, [1.0, -1.07e4], [1.0]),
                       (1.0, [1.0, 1430.0], [1.0]), (1.0, [1.0, 4.3e4, 3.2e9], [1.0]),
                       (1.0, [1.0], [1.0, 925.0, 4.59e5]), (1.0, [1.0], [1.0, 55.0, 1.4e7]),
                       (1.0, [1.0], [1.0, 1.54e4, 4e9]), (1.0, [1.0], [1.0, 964.0, 3.95e9])],
    "ahmad2020_Hm": [(0.02, [1.0, 2 * 3.5 * 6.3e3, 6.3e3 ** 2], [1.0, 2 * 0.05 * 6.3e3, 6.3e3 ** 2]),
                     (1.0, [1.0, 2 * 0.7 * 1.4e4, 1.4e4 ** 2], [1.0, 2 * 0.08 * 1.4e4, 1.4e4 ** 2]),
                     (1.0, [1e-8, 1e4], [1.0, 1e4])],
    "resonance_18kHz": [(1.0, [(2 * np.pi * 18e3) ** 2], [1.0, 2 * 0.05 * 2 * np.pi * 18e3, (2 * np.pi * 18e3) ** 2])],
    "lag_3kHz": [(1.0, [2 * np.pi * 3e3], [1.0, 2 * np.pi * 3e3])],
}

# name, model, rate (Hz), method, prewarp (Hz, 0 = none)
CASES = [
    ("K_100k_tustin", "ahmad2020_K", 1e5, "tustin", 0.0),
    ("K_10k_tustin", "ahmad2020_K", 1e4, "tustin", 0.0),
    ("K_100k_zoh", "ahmad2020_K", 1e5, "zoh", 0.0),
    ("K_100k_matched", "ahmad2020_K", 1e5, "matched", 0.0),
    ("G_100k_tustin", "ahmad2020_G", 1e5, "tustin", 0.0),
    ("G_100k_zoh", "ahmad2020_G", 1e5, "zoh", 0.0),
    ("G_10k_zoh", "ahmad2020_G", 1e4, "zoh", 0.0),
    ("C_5k_tustin", "janaideh2016_C", 5e3, "tustin", 0.0),
    ("C_5k_zoh", "janaideh2016_C", 5e3, "zoh", 0.0),
    ("D_5k_tustin", "janaideh2016_D", 5e3, "tustin", 0.0),
    ("D_5k_zoh", "janaideh2016_D", 5e3, "zoh", 0.0),
    ("D_5k_matched", "janaideh2016_D", 5e3, "matched", 0.0),
    ("Hm_100k_tustin_prewarp1k", "ahmad2020_Hm", 1e5, "tustin", 1e3),
    ("res18k_100k_tustin_prewarp18k", "resonance_18kHz", 1e5, "tustin", 18e3),
    ("res18k_100k_zoh", "resonance_18kHz", 1e5, "zoh", 0.0),
    ("lag3k_100k_zoh", "lag_3kHz", 1e5, "zoh", 0.0),
    ("lag3k_100k_matched", "lag_3kHz", 1e5, "matched", 0.0),
]


def mp_roots(p):
    p = [mp.mpf(c) for c in p]
    if len(p) <= 1:
        return []
    return list(mp.polyroots(p, maxsteps=500, extraprec=200))


def zpk_of(factors):
    gain = mp.mpf(1)
    zeros, poles = [], []
    for g, n, d in factors:
        gain *= mp.mpf(g) * mp.mpf(n[0]) / mp.mpf(d[0])
        zeros += mp_roots(n)
        poles += mp_roots(d)
    return zeros, poles, gain


def h_cont(zpk, s):
    z, p, k = zpk
    v = k
    for r in z:
        v *= s - r
    for r in p:
        v /= s - r
    return v


def response(zpk, method, ts, prewarp_hz, freqs):
    z, p, k = zpk
    out = []
    if method == "tustin":
        if prewarp_hz > 0:
            wp = 2 * mp.pi * mp.mpf(prewarp_hz)
            K = wp / mp.tan(wp * mp.mpf(ts) / 2)
        else:
            K = 2 / mp.mpf(ts)
        for f in freqs:
            x = mp.expj(2 * mp.pi * mp.mpf(f) * mp.mpf(ts))
            out.append(h_cont(zpk, K * (x - 1) / (x + 1)))
    elif method == "zoh":
        h0 = h_cont(zpk, mp.mpf(0))
        res = []
        for i, pi in enumerate(p):
            v = k
            for r in z:
                v *= pi - r
            for j, pj in enumerate(p):
                if j != i:
                    v /= pi - pj
            res.append((v / pi, mp.exp(pi * mp.mpf(ts))))
        for f in freqs:
            x = mp.expj(2 * mp.pi * mp.mpf(f) * mp.mpf(ts))
            out.append(h0 + sum(r * (x - 1) / (x - e) for r, e in res))
    else:  # matched
        zd = [mp.exp(r * mp.mpf(ts)) for r in z] + [mp.mpf(-1)] * (len(p) - len(z))
        pd = [mp.exp(r * mp.mpf(ts)) for r in p]

        def hd(x):
            v = mp.mpf(1)
            for r in zd:
                v *= x - r
            for r in pd:
                v /= x - r
            return v
        g = h_cont(zpk, mp.mpf(0)) / hd(mp.mpf(1))
        for f in freqs:
            out.append(g * hd(mp.expj(2 * mp.pi * mp.mpf(f) * mp.mpf(ts))))
    return [[float(mp.re(v)), float(mp.im(v))] for v in out]


def cplx_list(v):
    return [[float(np.real(x)), float(np.imag(x))] for x in v]


def main():
    out = []
    for name, model, rate, method, prewarp in CASES:
        factors = MODELS[model]
        zpk = zpk_of(factors)
        ts = 1.0 / rate
        freqs = [float(f) for f in np.logspace(-1, np.log10(0.4999 * rate), 25)]
        case = {"name": name, "model": model, "rate_hz": rate, "method": method, "prewarp_hz": prewarp,
                "factors": [{"gain": g, "num": n, "den": d} for g, n, d in factors],
                "freqs_hz": freqs, "h": response(zpk, method, ts, prewarp, freqs)}
        z = np.array([complex(r) for r in zpk[0]])
        p = np.array([complex(r) for r in zpk[1]])
        k = float(zpk[2])
        if method == "tustin":
            fs = rate
            if prewarp > 0:
                wp = 2 * np.pi * prewarp
                fs = wp / np.tan(wp / rate / 2) / 2
            zd, pd, kd = signal.bilinear_zpk(z, p, k, fs)
            case["scipy_zeros"] = cplx_list(zd)
            case["scipy_poles"] = cplx_list(pd)
            case["scipy_gain"] = float(kd)
        elif method == "zoh" and len(p) <= 2:
            num, den = signal.zpk2tf(z, p, k)
            numd, dend, _ = signal.cont2discrete((np.real(num), np.real(den)), 1.0 / rate, method="zoh")
            case["scipy_num"] = [float(c) for c in np.atleast_1d(np.squeeze(numd))]
            case["scipy_den"] = [float(c) for c in dend]
        out.append(case)
    path = os.path.join(os.path.dirname(__file__), "..", "..", "tests", "golden", "design_c2d.json")
    with open(path, "w") as f:
        json.dump(out, f, indent=1)
        f.write("\n")


if __name__ == "__main__":
    main()
