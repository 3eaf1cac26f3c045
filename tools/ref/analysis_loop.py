#!/usr/bin/python3
"""Loop analysis references (for host/analysis/analysis.cpp and margins.cpp),
computed from the factored frequency responses with numpy/scipy only:
L = P K evaluated from roots, S = 1/(1+L), T = L/(1+L), KS = K S, GS = P S;
H-infinity norms as the maximum over a 100k-point grid refined by a bounded
scalar optimiser; margins by brentq on log|L| (gain crossovers) and on the
phase relative to odd multiples of 180 degrees (phase crossovers), bracketed
on the unwrapped grid phase; bandwidth by brentq on |T| = |T(0)|/sqrt(2);
closed-loop poles as numpy roots of den_P den_K + num_P num_K.
Run with Debian's /usr/bin/python3; writes tests/golden/analysis_loop.json."""
import json
import math
import os
import warnings

import numpy as np
from scipy import optimize, signal


def zpk_json(z, p, k, ts):
    return {"zeros": [[float(np.real(r)), float(np.imag(r))] for r in z],
            "poles": [[float(np.real(r)), float(np.imag(r))] for r in p],
            "gain": float(np.real(k)), "ts": ts}


def resp(m, x):
    h = np.full_like(x, m["gain"], dtype=complex)
    for re, im in m["zeros"]:
        h = h * (x - complex(re, im))
    for re, im in m["poles"]:
        h = h / (x - complex(re, im))
    return h


def point(w, ts):
    w = np.asarray(w, dtype=float)
    return np.exp(1j * w * ts) if ts > 0 else 1j * w


def maps(P, K, ts):
    def f(name):
        def g(w):
            x = point(w, ts)
            p, k = resp(P, x), resp(K, x)
            s = 1.0 / (1.0 + p * k)
            return {"S": s, "T": p * k * s, "KS": k * s, "GS": p * s, "L": p * k, "P": p, "K": k}[name]
        return g
    return f


def grid(P, K, ts):
    mags = []
    for m in (P, K):
        for re, im in m["zeros"] + m["poles"]:
            r = complex(re, im)
            if ts > 0:
                if abs(r) == 0:
                    continue
                r = np.log(r) / ts
            if abs(r) > 0:
                mags.append(abs(r))
    lo = min(mags) * 1e-3 if mags else 1e-3
    hi = math.pi / ts if ts > 0 else max(mags) * 1e3
    return np.geomspace(lo, hi, 100000)


def hinf(fun, w):
    mag = np.abs(fun(w))
    best, wbest = float(mag.max()), float(w[mag.argmax()])
    for i in np.argsort(mag)[::-1][:5]:
        lo, hi = w[max(i - 2, 0)], w[min(i + 2, len(w) - 1)]
        res = optimize.minimize_scalar(lambda v: -float(np.abs(fun(v))), bounds=(lo, hi), method="bounded",
                                       options={"xatol": 1e-12 * hi})
        if -res.fun > best:
            best, wbest = float(-res.fun), float(res.x)
    return best, wbest


def margins(L, w):
    h = L(w)
    ph = np.unwrap(np.angle(h))
    lm = np.log(np.abs(h))
    gc, pc = [], []
    for i in range(len(w) - 1):
        if (lm[i] < 0) != (lm[i + 1] < 0):
            wc = optimize.brentq(lambda v: math.log(abs(L(v))), w[i], w[i + 1], xtol=1e-14 * w[i], rtol=1e-14)
            pm = math.degrees(math.remainder(float(np.angle(L(wc))) + math.pi, 2 * math.pi))
            gc.append({"w": wc, "pm_deg": pm})
        lo, hi = sorted((ph[i], ph[i + 1]))
        k = math.ceil((lo / math.pi - 1) / 2)
        while (2 * k + 1) * math.pi <= hi:
            t = (2 * k + 1) * math.pi
            f = lambda v: float(np.angle(L(v) * np.exp(-1j * t)))
            # A crossing where |L| < 1e-9 (a zero of L at Nyquist) has an
            # infinite gain margin and is not listed.
            if t > lo and f(w[i]) * f(w[i + 1]) < 0 and abs(h[i + 1]) > 1e-9:
                wc = optimize.brentq(f, w[i], w[i + 1], xtol=1e-14 * w[i], rtol=1e-14)
                gm = 1.0 / abs(complex(L(wc)))
                pc.append({"w": wc, "gm_db": 20 * math.log10(gm)})
            k += 1
    return gc, pc


def bandwidth(T, w, ts):
    t0 = abs(complex(T(w[0] * 1e-6)))  # (an integrator in K or P: T(0) as a limit)
    level = t0 / math.sqrt(2)
    mag = np.abs(T(w))
    idx = np.nonzero(mag < level)[0]
    if len(idx) == 0:
        return None
    i = idx[0]
    return optimize.brentq(lambda v: abs(complex(T(v))) - level, w[i - 1], w[i], xtol=1e-14 * w[i], rtol=1e-14)


def polys(m):
    num = np.real(np.poly([complex(*r) for r in m["zeros"]])) * m["gain"]
    den = np.real(np.poly([complex(*r) for r in m["poles"]]))
    return num, den


def case(name, P, K, weights=None):
    ts = P["ts"]
    f = maps(P, K, ts)
    w = grid(P, K, ts)
    out = {"name": name, "plant": P, "controller": K}
    for m in ("S", "T", "KS", "GS"):
        v, wp = hinf(f(m), w)
        out["hinf_" + m] = v
        out["peak_w_" + m] = wp
    gc, pc = margins(f("L"), w)
    out["gain_crossovers"] = gc
    out["phase_crossovers"] = pc
    out["bandwidth_w"] = bandwidth(f("T"), w, ts)
    nP, dP = polys(P)
    nK, dK = polys(K)
    r = np.roots(np.polyadd(np.polymul(dP, dK), np.polymul(nP, nK)))
    out["stability_measure"] = float(max(abs(r))) if ts > 0 else float(max(r.real))
    for wname, W, mapname, key in (weights or []):
        fun = lambda v, W=W, mapname=mapname: resp(W, point(v, ts)) * f(mapname)(v)
        out["hinf_" + wname], _ = hinf(fun, w)
        out[key] = W
    return out


def main():
    # Grid points on a pole of L (an integrator at DC) give inf/nan; they
    # are never maxima and are skipped by the brackets.
    warnings.simplefilter("ignore", RuntimeWarning)
    cases = []
    # 2/(s+1)^3 under unity feedback (known margins, see the C++ test).
    cases.append(case("third_order", zpk_json([], [-1, -1, -1], 1.0, 0.0), zpk_json([], [], 2.0, 0.0)))
    # Lightly damped plant with a PI-like controller (two gain crossovers).
    wn = 2 * math.pi * 1e3
    pr = np.roots([1, 2 * 0.02 * wn, wn * wn])
    cases.append(case("resonance_pi", zpk_json([], pr, wn * wn, 0.0), zpk_json([-300.0], [0.0], 0.4, 0.0)))
    # Ahmad2020 G (eq. 4) and K (eq. 24) with the coefficient order of docs/models.md.
    g_num = [2.01e11, 4.74e15, 2.76e19, 1.84e23]
    g_den = [1.0, 1.08e4, 2.95e8, 1.98e12, 1.65e16, 5.79e19, 2.05e23]
    k_num = [5.29e6, 1.78e10, 1.04e15, 7.66e17, 1.51e22, 4.73e22]
    k_den = [1.0, 4.69e5, 3.21e10, 7.86e14, 7.38e18, 4.71e19, 7.79e19]
    G = zpk_json(np.roots(g_num), np.roots(g_den), g_num[0], 0.0)
    K = zpk_json(np.roots(k_num), np.roots(k_den), k_num[0], 0.0)
    Me, ee, we = 2.0, 0.003, 1.26e3
    He = zpk_json([-Me * we], [-we * ee], 1.0 / Me, 0.0)
    My, ey, wy = 1.5, 1e-4, 7.5e3
    Hy = zpk_json([-wy / My] * 2, [-wy / ey] * 2, 1.0 / ey ** 2, 0.0)
    g, z1, z2, z3, z4, w1, w2, w3, M, eps = 0.02, 3.5, 0.05, 0.7, 0.08, 6.3e3, 1.4e4, 1e4, 1.0, 1e-8
    Hm = zpk_json(list(np.roots([1, 2 * z1 * w1, w1 ** 2])) + list(np.roots([1, 2 * z3 * w2, w2 ** 2])) + [-w3 / eps],
                  list(np.roots([1, 2 * z2 * w1, w1 ** 2])) + list(np.roots([1, 2 * z4 * w2, w2 ** 2])) + [-w3 / M],
                  g * eps, 0.0)
    cases.append(case("ahmad2020", G, K, [("WeS", He, "S", "He"), ("WyT", Hy, "T", "Hy"), ("HmT", Hm, "T", "Hm")]))
    # Discrete: first-order lag with an integrating controller at 10 kHz.
    cases.append(case("discrete_lag_integrator", zpk_json([], [0.9], 0.1, 1e-4), zpk_json([0.0], [1.0], 0.5, 1e-4)))
    # Discrete: Shan2012-style PI (Kp = 1.3, Ki = 40000 at 100 kHz) on an
    # 18 kHz resonance (zeta 0.05) discretised by Tustin.
    fs = 1e5
    wr = 2 * math.pi * 18e3
    zp, pp, kp = signal.bilinear_zpk([], np.roots([1, 2 * 0.05 * wr, wr * wr]), wr * wr, fs)
    kp_, ki = 1.3, 40000.0
    # Gc = Kp + Ki Ts z/(z-1) = (Kp + Ki Ts) (z - Kp/(Kp + Ki Ts)) / (z - 1)
    kc = kp_ + ki / fs
    cases.append(case("shan2012_pi_resonance_unstable", zpk_json(zp, pp, kp, 1.0 / fs),
                      zpk_json([kp_ / kc], [1.0], kc, 1.0 / fs)))
    zp, pp, kp = signal.bilinear_zpk([], np.roots([1, 2 * 0.1 * wr, wr * wr]), wr * wr, fs)
    cases.append(case("shan2012_pi_resonance_damped", zpk_json(zp, pp, kp, 1.0 / fs),
                      zpk_json([kp_ / kc], [1.0], kc, 1.0 / fs)))
    # Janaideh2016 D(s) (eq. 60) under C(s) (eq. 75), factored as published.
    dz = [1.22e5, -2.99e4, 2.776e4, 1.07e4, -1430.0] + list(np.roots([1.0, 4.3e4, 3.2e9]))
    dp = []
    for q in ([1.0, 925.0, 4.59e5], [1.0, 55.0, 1.4e7], [1.0, 1.54e4, 4e9], [1.0, 964.0, 3.95e9]):
        dp += list(np.roots(q))
    cz = [-7.9e6] + list(np.roots([1.0, 971.0, 4.6e5])) + list(np.roots([1.0, 43.0, 1.4e7]))
    cp = [-8.8e4, -974.0, -1.0] + list(np.roots([1.0, 1153.0, 1.6e7]))
    cases.append(case("janaideh2016", zpk_json(dz, dp, -20.7, 0.0), zpk_json(cz, cp, 0.016, 0.0)))
    path = os.path.join(os.path.dirname(__file__), "..", "..", "tests", "golden", "analysis_loop.json")
    with open(path, "w") as f:
        json.dump({"cases": cases}, f, indent=1)
        f.write("\n")


if __name__ == "__main__":
    main()
