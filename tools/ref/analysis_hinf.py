#!/usr/bin/python3
"""H-infinity norms of the sources' models, by brute force with numpy/scipy
(reference for host/analysis/hinf.cpp, whose method is a Hamiltonian level-set
iteration). Each model is split into sections of one or two poles (numpy
roots of the published polynomials, scipy's bilinear_zpk for the discrete
ones); the sections' roots are written out so the C++ test realises the very
same factored model, and both sides evaluate it from its roots (never from
multiplied-out coefficients, which lose 7 digits near |z| = 0.99997). The reference value is
the maximum of |G| on a 200k-point grid, refined by scipy's bounded scalar
minimiser around the best grid points.
Run with Debian's /usr/bin/python3; writes tests/golden/analysis_hinf.json."""
import json
import math
import os

import numpy as np
from scipy import optimize, signal


def groups(roots):
    """Roots grouped as the real sections hold them: conjugate pairs (+imag
    member first), pairs of real roots, at most one single real root."""
    cplx = sorted([r for r in roots if r.imag > 0], key=abs)
    real = sorted([r.real for r in roots if r.imag == 0], key=abs)
    out = [[r, r.conjugate()] for r in cplx]
    while len(real) >= 2:
        out.append([complex(real.pop(0)), complex(real.pop(0))])
    if real:
        out.append([complex(real[0])])
    return out


def clean(roots, tol=1e-12):
    out = []
    for r in roots:
        r = complex(r)
        if abs(r.imag) <= tol * abs(r):
            r = complex(r.real, 0.0)
        out.append(r)
    return out


def sections(zeros, poles, gain, ts):
    """Sections of one or two poles with at most as many zeros each (so each
    is proper). Each section is scaled to unit gain at its poles' natural
    frequency and the model's gain is spread evenly over the sections, so no
    state of the cascade is 1e12 times larger than another."""
    dens = groups(clean(poles))
    nums = groups(clean(zeros))
    if sum(map(len, nums)) > sum(map(len, dens)):
        raise ValueError("improper model")
    # Each zero group goes with the free pole group nearest in magnitude
    # (pairs first), as SOS pairing does: a zero far below its section's
    # poles would make the section's DC gain a difference of near-equal terms.
    mag = lambda g: max(abs(g[0]), 1e-300)
    assigned = [None] * len(dens)
    for zg in sorted(nums, key=len, reverse=True):
        free = [i for i in range(len(dens)) if assigned[i] is None and len(dens[i]) >= len(zg)]
        i = min(free, key=lambda k: abs(math.log(mag(dens[k])) - math.log(mag(zg))))
        assigned[i] = zg
    secs = []
    for d, n in zip(dens, assigned):
        n = n or []
        secs.append({"zeros": [[r.real, r.imag] for r in n], "poles": [[r.real, r.imag] for r in d],
                     "gain": 1.0})
    total = gain
    for sec in secs:
        w = math.sqrt(abs(np.prod([complex(*p) for p in sec["poles"]]))) if ts == 0 else \
            abs(np.log(complex(*sec["poles"][0]))) / ts
        x = 1j * w if ts == 0 else np.exp(1j * w * ts)
        sec["gain"] = 1.0
        h = abs(response([sec], np.array([x]))[0])
        sec["gain"] = 1.0 / h
        total *= h
    k = abs(total) ** (1.0 / len(secs))
    for sec in secs:
        sec["gain"] = float(sec["gain"] * k)
    secs[0]["gain"] *= float(np.sign(total))
    return secs


def response(secs, x):
    h = np.ones_like(x, dtype=complex)
    for s in secs:
        h = h * s["gain"]
        for re, im in s["zeros"]:
            h = h * (x - complex(re, im))
        for re, im in s["poles"]:
            h = h / (x - complex(re, im))
    return h


def peak(secs, ts, wmin, wmax):
    if ts > 0:
        w = np.concatenate([[0.0], np.geomspace(wmin, math.pi / ts, 200000)])
        f = lambda w_: np.abs(response(secs, np.exp(1j * np.asarray(w_) * ts)))
    else:
        w = np.concatenate([[0.0], np.geomspace(wmin, wmax, 200000)])
        f = lambda w_: np.abs(response(secs, 1j * np.asarray(w_)))
    mag = f(w)
    order = np.argsort(mag)[::-1][:5]
    best, wbest = float(mag[order[0]]), float(w[order[0]])
    for i in order:
        lo, hi = w[max(i - 2, 0)], w[min(i + 2, len(w) - 1)]
        if hi <= lo:
            continue
        res = optimize.minimize_scalar(lambda v: -float(f(v)), bounds=(lo, hi), method="bounded",
                                       options={"xatol": 1e-12 * hi})
        if -res.fun > best:
            best, wbest = float(-res.fun), float(res.x)
    if ts == 0:
        # |G(j inf)| for biproper models.
        nz = sum(len(s["zeros"]) for s in secs)
        npl = sum(len(s["poles"]) for s in secs)
        if nz == npl:
            dinf = abs(np.prod([s["gain"] for s in secs]))
            if dinf > best:
                best, wbest = dinf, math.inf
    return best, wbest


def main():
    cases = []
    # Ahmad2020 K(s) (eq. 24) and G(s) (eq. 4); docs/models.md, 'Published controllers', 'Ahmad2020'.
    k_num = [5.29e6, 1.78e10, 1.04e15, 7.66e17, 1.51e22, 4.73e22]
    k_den = [1.0, 4.69e5, 3.21e10, 7.86e14, 7.38e18, 4.71e19, 7.79e19]
    g_num = [2.01e11, 4.74e15, 2.76e19, 1.84e23]
    g_den = [1.0, 1.08e4, 2.95e8, 1.98e12, 1.65e16, 5.79e19, 2.05e23]
    models = [
        ("ahmad2020_K", np.roots(k_num), np.roots(k_den), k_num[0], 0.0),
        ("ahmad2020_G", np.roots(g_num), np.roots(g_den), g_num[0], 0.0),
    ]
    # Janaideh2016 D(s) (eq. 60) and C(s) (eq. 75), factored as published.
    d_zeros = [1.22e5, -2.99e4, 2.776e4, 1.07e4, -1430.0] + list(np.roots([1.0, 4.3e4, 3.2e9]))
    d_poles = []
    for q in ([1.0, 925.0, 4.59e5], [1.0, 55.0, 1.4e7], [1.0, 1.54e4, 4e9], [1.0, 964.0, 3.95e9]):
        d_poles += list(np.roots(q))
    models.append(("janaideh2016_D", np.array(d_zeros, dtype=complex), np.array(d_poles), -20.7, 0.0))
    c_zeros = [-7.9e6] + list(np.roots([1.0, 971.0, 4.6e5])) + list(np.roots([1.0, 43.0, 1.4e7]))
    c_poles = [-8.8e4, -974.0, -1.0] + list(np.roots([1.0, 1153.0, 1.6e7]))
    models.append(("janaideh2016_C", np.array(c_zeros, dtype=complex), np.array(c_poles, dtype=complex), 0.016, 0.0))
    # Ahmad2020 weights (docs/models.md, 'Ahmad2020').
    g, z1, z2, z3, z4, w1, w2, w3, M, eps = 0.02, 3.5, 0.05, 0.7, 0.08, 6.3e3, 1.4e4, 1e4, 1.0, 1e-8
    hm_z = list(np.roots([1.0, 2 * z1 * w1, w1 ** 2])) + list(np.roots([1.0, 2 * z3 * w2, w2 ** 2])) + [-w3 / eps]
    hm_p = list(np.roots([1.0, 2 * z2 * w1, w1 ** 2])) + list(np.roots([1.0, 2 * z4 * w2, w2 ** 2])) + [-w3 / M]
    models.append(("ahmad2020_Hm", np.array(hm_z, dtype=complex), np.array(hm_p, dtype=complex), g * eps, 0.0))
    # Discrete: K(s) by Tustin at 100 kHz (poles at |z| ~ 0.99997), and a
    # lightly damped 18 kHz resonance.
    fs = 1e5
    zk, pk, kk = signal.bilinear_zpk(np.roots(k_num), np.roots(k_den), k_num[0], fs)
    models.append(("ahmad2020_K_tustin_100kHz", zk, pk, kk, 1.0 / fs))
    wn = 2 * math.pi * 18e3
    zr, pr, kr = signal.bilinear_zpk([], np.roots([1.0, 2 * 0.01 * wn, wn * wn]), wn * wn, fs)
    models.append(("resonance_18kHz_tustin_100kHz", zr, pr, kr, 1.0 / fs))

    for name, zeros, poles, gain, ts in models:
        secs = sections(list(zeros), list(poles), float(np.real(gain)), ts)
        if ts > 0:
            wp = [abs(np.log(complex(p))) / ts for p in poles if abs(p) > 0]
        else:
            wp = [abs(p) for p in poles]
        wmin, wmax = min(wp) * 1e-4, max(wp) * 1e4
        h, wpk = peak(secs, ts, wmin, wmax)
        stable = all((abs(p) < 1.0) if ts > 0 else (p.real < 0.0) for p in poles)
        cases.append({"name": name, "ts": ts, "sections": secs, "hinf": h,
                      "peak_w": wpk if math.isfinite(wpk) else None, "w_scale": min(wp),
                      "stable": bool(stable)})
    path = os.path.join(os.path.dirname(__file__), "..", "..", "tests", "golden", "analysis_hinf.json")
    with open(path, "w") as f:
        json.dump({"cases": cases}, f, indent=1)
        f.write("\n")


if __name__ == "__main__":
    main()
