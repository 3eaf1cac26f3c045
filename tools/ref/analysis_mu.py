#!/usr/bin/python3
"""References for the structured singular value upper bound
(host/analysis/mu.cpp, tests/host/analysis/test_mu.cpp,
tests/host/cli/check_analyze_mu.py), by brute force with numpy alone: no
Osborne start, no gradient, no BFGS.

Matrices: seeded complex Gaussian matrices for block structures
(z_size, w_size) per block. For one free scaling (two blocks) the upper bound
inf_d sigma_max(D_z M D_w^-1) is found by a log-spaced grid of 40001 values of
d over [1e-8, 1e8], then a bounded scalar search between the grid neighbours
of the best point (tolerance 1e-12 in log d). For two free scalings (three
blocks), a 401 x 401 grid over [1e-4, 1e4]^2, then Nelder-Mead from the best
point (xatol 1e-11, fatol 1e-15). For three free scalings (four scalar
blocks), the first seeded matrix whose optimum has a repeated sigma_max (so
that the bound is nonsmooth there and mu lies below it): a 41^3 grid then
Nelder-Mead from six starts. The minimum is stored with the optimal d.

Ahmad2020 loop (docs/models.md, 'Ahmad2020'; configs/models/ahmad2020_*.json):
robust stability |H_m T|, nominal performance sqrt(|H_e S|^2 + |H_y T|^2) and
the robust-performance bound of N = [[-H_m T, H_m K S], [-H_e G S, H_e S],
[H_y G S, H_y T]] for blocks (1x1, 1x2), each on 6001 frequencies from 1 Hz
to 1 MHz, the peak then refined by a bounded search in log f between the
neighbours of the best grid point (the rp value at each frequency by the
bounded scalar search in log d on [1e-6, 1e6] after a 201-point grid).
Run with Debian's /usr/bin/python3; writes tests/golden/analysis_mu.json."""
import json
import os

import numpy as np
from scipy import optimize

G_NUM = [2.01e11, 4.74e15, 2.76e19, 1.84e23]
G_DEN = [1.0, 1.08e4, 2.95e8, 1.98e12, 1.65e16, 5.79e19, 2.05e23]
K_NUM = [5.29e6, 1.78e10, 1.04e15, 7.66e17, 1.51e22, 4.73e22]
K_DEN = [1.0, 4.69e5, 3.21e10, 7.86e14, 7.38e18, 4.71e19, 7.79e19]
HM = ([0.02 * 1e-8], list(np.roots([1, 44100, 3.969e7])) + list(np.roots([1, 19600, 1.96e8])) + [-1e4 / 1e-8],
      list(np.roots([1, 630, 3.969e7])) + list(np.roots([1, 2240, 1.96e8])) + [-1e4])
HE = ([0.5], [-1260 / 0.5], [-3.78])
HY = ([(1 / 1e-4) ** 2], [-5000.0, -5000.0], [-7.5e7, -7.5e7])


def zpk_resp(z, p, k, s):
    h = k * np.ones_like(s, dtype=complex)
    for r in z:
        h = h * (s - r)
    for r in p:
        h = h / (s - r)
    return h


def scaled_sigma(m, blocks, d):
    return scaled_sigmas(m, blocks, np.asarray(d, dtype=float)[None, :])[0]


def scaled_sigmas(m, blocks, d):
    """sigma_max of D m D^-1 for each row of d (one scaling per block): one
    batched SVD, so the grids below cost seconds, not minutes."""
    rows = np.repeat(np.arange(len(blocks)), [b[0] for b in blocks])
    cols = np.repeat(np.arange(len(blocks)), [b[1] for b in blocks])
    a = (d[:, rows, None] * m[None, :, :]) / d[:, None, cols]
    return np.linalg.svd(a, compute_uv=False)[:, 0]


def brute_1(m, blocks, lo=-8.0, hi=8.0, n=40001):
    xs = np.linspace(lo * np.log(10), hi * np.log(10), n)
    f = scaled_sigmas(m, blocks, np.stack([np.exp(xs), np.ones(n)], axis=1))
    i = int(np.argmin(f))
    a, b = xs[max(i - 1, 0)], xs[min(i + 1, n - 1)]
    res = optimize.minimize_scalar(lambda x: scaled_sigma(m, blocks, [np.exp(x), 1.0]), bounds=(a, b),
                                   method="bounded", options={"xatol": 1e-12})
    if res.fun < f[i]:
        return float(res.fun), [float(np.exp(res.x)), 1.0]
    return float(f[i]), [float(np.exp(xs[i])), 1.0]


def brute_2(m, blocks):
    xs = np.linspace(-4 * np.log(10), 4 * np.log(10), 401)
    x0, x1 = (g.ravel() for g in np.meshgrid(xs, xs, indexing="ij"))
    v = scaled_sigmas(m, blocks, np.stack([np.exp(x0), np.exp(x1), np.ones(x0.size)], axis=1))
    i = int(np.argmin(v))
    best, bx = v[i], (x0[i], x1[i])
    res = optimize.minimize(lambda x: scaled_sigma(m, blocks, [np.exp(x[0]), np.exp(x[1]), 1.0]), bx,
                            method="Nelder-Mead", options={"xatol": 1e-11, "fatol": 1e-15, "maxiter": 20000})
    if res.fun < best:
        best, bx = res.fun, res.x
    return float(best), [float(np.exp(bx[0])), float(np.exp(bx[1])), 1.0]


def brute_3_nonsmooth(rng):
    """Four scalar blocks (three free scalings): random 4 x 4 matrices until
    one whose optimum has a repeated sigma_max (the nonsmooth case where mu
    is below the bound). A 41^3 grid over [1e-3, 1e3]^3, then Nelder-Mead
    from the best grid point and from five random starts."""
    blocks = [(1, 1)] * 4
    while True:
        m = random_matrix(rng, 4, 4)

        def f(x):
            return scaled_sigma(m, blocks, list(np.exp(x)) + [1.0])

        xs = np.linspace(-3 * np.log(10), 3 * np.log(10), 41)
        grid = np.stack([g.ravel() for g in np.meshgrid(xs, xs, xs, indexing="ij")], axis=1)
        v = scaled_sigmas(m, blocks, np.concatenate([np.exp(grid), np.ones((len(grid), 1))], axis=1))
        starts = [grid[int(np.argmin(v))]] + [rng.normal(size=3) for _ in range(5)]
        best = min((optimize.minimize(f, x0, method="Nelder-Mead",
                                      options={"xatol": 1e-12, "fatol": 1e-15, "maxiter": 40000}) for x0 in starts),
                   key=lambda r: r.fun)
        d = list(np.exp(best.x)) + [1.0]
        zs = np.array(d)
        sv = np.linalg.svd((zs[:, None] * m) / zs[None, :], compute_uv=False)
        if sv[1] > sv[0] * (1 - 1e-5):
            return m, blocks, float(best.fun), [float(x) for x in d]


def random_matrix(rng, rows, cols):
    return rng.standard_normal((rows, cols)) + 1j * rng.standard_normal((rows, cols))


def matrix_cases():
    rng = np.random.default_rng(20261201)
    structures = [
        ("two_scalar", [(1, 1), (1, 1)], 4),
        ("two_full_2x2", [(2, 2), (2, 2)], 3),
        ("scalar_and_full_3x3", [(1, 1), (3, 3)], 2),
        ("nonsquare_1x1_and_2x1", [(1, 1), (2, 1)], 3),
        ("three_scalar", [(1, 1), (1, 1), (1, 1)], 2),
        ("scalar_full2_scalar", [(1, 1), (2, 2), (1, 1)], 1),
    ]
    cases = []
    for name, blocks, count in structures:
        rows, cols = sum(b[0] for b in blocks), sum(b[1] for b in blocks)
        for k in range(count):
            m = random_matrix(rng, rows, cols)
            # Unbalance the blocks so that the optimum is far from d = 1.
            m[: blocks[0][0], blocks[0][1]:] *= 30.0
            m[blocks[0][0]:, : blocks[0][1]] /= 30.0
            mu, d = brute_1(m, blocks) if len(blocks) == 2 else brute_2(m, blocks)
            cases.append({"name": f"{name}_{k}", "blocks": [list(b) for b in blocks],
                          "re": m.real.tolist(), "im": m.imag.tolist(), "mu_upper": mu, "d": d})
    m, blocks, mu, d = brute_3_nonsmooth(rng)
    cases.append({"name": "four_scalar_repeated_sigma", "blocks": [list(b) for b in blocks],
                  "re": m.real.tolist(), "im": m.imag.tolist(), "mu_upper": mu, "d": d})
    return cases


def ahmad2020():
    gz, gp, kz, kp = np.roots(G_NUM), np.roots(G_DEN), np.roots(K_NUM), np.roots(K_DEN)

    def n_matrix(f_hz):
        s = 2j * np.pi * f_hz
        g, k = zpk_resp(gz, gp, G_NUM[0], s), zpk_resp(kz, kp, K_NUM[0], s)
        hm, he, hy = (zpk_resp(z, p, kk[0], s) for kk, z, p in (HM, HE, HY))
        sens = 1 / (1 + g * k)
        t = g * k * sens
        return np.array([[-hm * t, hm * k * sens], [-he * g * sens, he * sens], [hy * g * sens, hy * t]])

    blocks = [(1, 1), (2, 1)]

    def rp(f_hz):
        m = n_matrix(f_hz)
        return brute_1(m, blocks, lo=-6.0, hi=6.0, n=201)[0]

    measures = {
        "rs": lambda f: abs(n_matrix(f)[0, 0]),
        "np": lambda f: float(np.linalg.norm(n_matrix(f)[1:, 1])),
        "rp": rp,
    }
    fs = np.geomspace(1.0, 1e6, 6001)
    out = {}
    for key, fn in measures.items():
        v = np.array([fn(f) for f in fs])
        i = int(np.argmax(v))
        a, b = np.log(fs[max(i - 1, 0)]), np.log(fs[min(i + 1, len(fs) - 1)])
        res = optimize.minimize_scalar(lambda x: -fn(np.exp(x)), bounds=(a, b), method="bounded",
                                       options={"xatol": 1e-10})
        peak, at = (-res.fun, np.exp(res.x)) if -res.fun > v[i] else (v[i], fs[i])
        out[f"{key}_peak"] = float(peak)
        out[f"{key}_peak_hz"] = float(at)
    return out


def main():
    out = {"matrices": matrix_cases(), "ahmad2020": ahmad2020()}
    path = os.path.join(os.path.dirname(__file__), "..", "..", "tests", "golden", "analysis_mu.json")
    with open(path, "w") as f:
        json.dump(out, f, indent=1)
        f.write("\n")


if __name__ == "__main__":
    main()
