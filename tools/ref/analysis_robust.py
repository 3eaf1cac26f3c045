#!/usr/bin/python3
"""Ahmad2020 robust-stability family (reference for host/analysis/robust.cpp):
the 729 plants with each denominator coefficient of G(s) (eq. 4) scaled by
0.95, 1, 1.05, under K(s) (eq. 24), with the multiplicative weight H_m.
numpy only, from roots and factored responses: closed-loop stability from
numpy roots of den_Gi den_K + num_G num_K; ||H_m T_i|| (stable members only)
as the maximum over a 20k-point grid, refined by a bounded scalar optimiser
for the member with the largest grid value; coverage sup |G_i/G - 1| / |H_m|
likewise. Also the stability measure of every member, for a per-member
comparison.
Member order as in robust.cpp: index = sum_j (level_j + 1) 3^(j-1) with
level_j in {-1, 0, 1} the perturbation of den[j] (j = 1 for s^5).
Run with Debian's /usr/bin/python3; writes tests/golden/analysis_robust.json."""
import itertools
import json
import os

import numpy as np
from scipy import optimize

G_NUM = [2.01e11, 4.74e15, 2.76e19, 1.84e23]
G_DEN = [1.0, 1.08e4, 2.95e8, 1.98e12, 1.65e16, 5.79e19, 2.05e23]
K_NUM = [5.29e6, 1.78e10, 1.04e15, 7.66e17, 1.51e22, 4.73e22]
K_DEN = [1.0, 4.69e5, 3.21e10, 7.86e14, 7.38e18, 4.71e19, 7.79e19]
HM_Z = list(np.roots([1, 44100, 3.969e7])) + list(np.roots([1, 19600, 1.96e8])) + [-1e4 / 1e-8]
HM_P = list(np.roots([1, 630, 3.969e7])) + list(np.roots([1, 2240, 1.96e8])) + [-1e4]
HM_K = 0.02 * 1e-8


def zpk_resp(z, p, k, s):
    h = np.full_like(s, k, dtype=complex)
    for r in z:
        h = h * (s - r)
    for r in p:
        h = h / (s - r)
    return h


GZ, KZ = np.roots(G_NUM), np.roots(K_NUM)
KP = np.roots(K_DEN)


def refine_max(f, w):
    v = f(w)
    best = float(v.max())
    for i in np.argsort(v)[::-1][:5]:
        lo, hi = w[max(i - 1, 0)], w[min(i + 1, len(w) - 1)]
        res = optimize.minimize_scalar(lambda x: -float(f(np.array([x]))[0]), bounds=(lo, hi), method="bounded",
                                       options={"xatol": 1e-12 * hi})
        best = max(best, -res.fun)
    return best


def main():
    w = np.geomspace(1e-2, 1e7, 20000)
    s = 1j * w
    gnom = zpk_resp(GZ, np.roots(G_DEN), G_NUM[0], s)
    members = []
    for levels in itertools.product([-1, 0, 1], repeat=6):
        # itertools varies the last fastest; robust.cpp varies den[1] fastest.
        lv = levels[::-1]
        den = [G_DEN[0]] + [G_DEN[j + 1] * (1 + 0.05 * lv[j]) for j in range(6)]
        gp = np.roots(den)
        ch = np.polyadd(np.polymul(den, K_DEN), np.polymul(G_NUM, K_NUM))
        sm = float(max(np.roots(ch).real))
        members.append((lv, den, gp, sm))
    members.sort(key=lambda m: sum((l + 1) * 3 ** j for j, l in enumerate(m[0])))
    stab = [m[3] for m in members]
    worst = int(np.argmax(stab))

    def hmt(gp):
        def f(x):
            sx = 1j * np.asarray(x)
            l = zpk_resp(GZ, gp, G_NUM[0], sx) * zpk_resp(KZ, KP, K_NUM[0], sx)
            return np.abs(zpk_resp(HM_Z, HM_P, HM_K, sx) * l / (1 + l))
        return f

    def cov(gp):
        def f(x):
            sx = 1j * np.asarray(x)
            g = zpk_resp(GZ, gp, G_NUM[0], sx)
            gn = zpk_resp(GZ, np.roots(G_DEN), G_NUM[0], sx)
            return np.abs(g / gn - 1) / np.abs(zpk_resp(HM_Z, HM_P, HM_K, sx))
        return f

    # ||H_m T_i|| only means something for a stable closed loop.
    grid_hmt = [float(hmt(m[2])(w).max()) if m[3] < 0 else -np.inf for m in members]
    grid_cov = [float(cov(m[2])(w).max()) for m in members]
    i_h = int(np.argmax(grid_hmt))
    i_c = int(np.argmax(grid_cov))
    out = {
        "count": len(members),
        "unstable": int(sum(1 for v in stab if v >= 0)),
        "worst_stability_index": worst,
        "worst_stability_measure": stab[worst],
        "worst_stability_scale": [1 + 0.05 * l for l in members[worst][0]],
        "worst_hinf_HmT_index": i_h,
        "worst_hinf_HmT": refine_max(hmt(members[i_h][2]), w),
        "worst_coverage_index": i_c,
        "worst_coverage": refine_max(cov(members[i_c][2]), w),
        "stability_measures": stab,
    }
    path = os.path.join(os.path.dirname(__file__), "..", "..", "tests", "golden", "analysis_robust.json")
    with open(path, "w") as f:
        json.dump(out, f, indent=1)
        f.write("\n")


if __name__ == "__main__":
    main()
