#!/usr/bin/python3
"""Reference for host/lti/sos: scipy.signal.zpk2sos(pairing='nearest').

Inputs are discrete zpk sets given exactly (so both sides pair the same
numbers): the sources' models discretised by scipy.signal.bilinear_zpk at
their loop rates, and seeded random sets (real and complex roots, odd
counts, fewer zeros than poles, zeros outside and on the unit circle). For
some cases also the L1 norms of every partial cascade (sum of |impulse
response| by sosfilt over a record long enough to decay to 1e-13).
Run with Debian's /usr/bin/python3; writes tests/golden/design_sos.json.
"""
import json
import os

import numpy as np
from scipy import signal

MODELS = {
    "ahmad2020_K": ([5.29e6, 1.78e10, 1.04e15, 7.66e17, 1.51e22, 4.73e22],
                    [1.0, 4.69e5, 3.21e10, 7.86e14, 7.38e18, 4.71e19, 7.79e19]),
    "ahmad2020_G": ([2.01e11, 4.74e15, 2.76e19, 1.84e23],
                    [1.0, 1.08e4, 2.95e8, 1.98e12, 1.65e16, 5.79e19, 2.05e23]),
}


def d_zpk():
    z = np.concatenate([[1.22e5, -2.99e4, 2.776e4, 1.07e4, -1430.0], np.roots([1.0, 4.3e4, 3.2e9])])
    p = np.concatenate([np.roots(q) for q in ([1.0, 925.0, 4.59e5], [1.0, 55.0, 1.4e7],
                                              [1.0, 1.54e4, 4e9], [1.0, 964.0, 3.95e9])])
    return z, p, -20.7


def c_zpk():
    z = np.concatenate([[-7.9e6], np.roots([1.0, 971.0, 4.6e5]), np.roots([1.0, 43.0, 1.4e7])])
    p = np.concatenate([[-8.8e4, -974.0, -1.0], np.roots([1.0, 1153.0, 1.6e7])])
    return z, p, 0.016


def cplx_list(v):
    return [[float(np.real(x)), float(np.imag(x))] for x in v]


def sos_list(sos):
    return [[float(r[0]), float(r[1]), float(r[2]), float(r[4]), float(r[5])] for r in sos]


def partial_l1(sos):
    p = np.concatenate([np.roots(r[3:]) for r in sos])
    rho = max(np.max(np.abs(p)), 1e-3)
    n = int(np.ceil(np.log(1e-13) / np.log(rho))) + 64
    x = np.zeros(n)
    x[0] = 1.0
    return [float(np.sum(np.abs(signal.sosfilt(sos[:i + 1], x)))) for i in range(len(sos))]


def random_roots(rng, n, rmin, rmax, allow_real=True):
    out = []
    while len(out) < n:
        r = rng.uniform(rmin, rmax)
        if n - len(out) >= 2 and (not allow_real or rng.uniform() < 0.6):
            a = rng.uniform(0.01, np.pi - 0.01)
            out += [r * np.exp(1j * a), r * np.exp(-1j * a)]
        else:
            out.append(complex(r * (1 if rng.uniform() < 0.5 else -1), 0.0))
    return np.array(out)


def main():
    cases = []
    for name, (num, den) in MODELS.items():
        z, p, k = signal.tf2zpk(num, den)
        zd, pd, kd = signal.bilinear_zpk(z, p, k, fs=1e5)
        cases.append((f"{name}_100k", zd, pd, kd, True))
    for name, (z, p, k), fs in (("janaideh2016_D_5k", d_zpk(), 5e3), ("janaideh2016_C_5k", c_zpk(), 5e3)):
        zd, pd, kd = signal.bilinear_zpk(z, p, k, fs=fs)
        cases.append((name, zd, pd, kd, True))
    rng = np.random.default_rng(20240611)
    for t in range(40):
        n_p = int(rng.integers(1, 10))
        n_z = int(rng.integers(0, n_p + 1))
        p = random_roots(rng, n_p, 0.05, 0.9995)
        z = random_roots(rng, n_z, 0.1, 2.0)
        if t % 5 == 0 and n_z >= 2:
            z[:2] = [np.exp(1j * 0.7), np.exp(-1j * 0.7)]  # zeros on the unit circle (a notch)
        k = float(rng.uniform(0.1, 10.0))
        cases.append((f"random_{t}", z, p, k, t < 5))
    out = []
    for name, z, p, k, with_l1 in cases:
        sos = signal.zpk2sos(z, p, k, pairing="nearest")
        c = {"name": name, "zeros": cplx_list(z), "poles": cplx_list(p), "gain": float(np.real(k)),
             "sos": sos_list(sos)}
        if with_l1:
            c["partial_l1"] = partial_l1(sos)
        out.append(c)
    path = os.path.join(os.path.dirname(__file__), "..", "..", "tests", "golden", "design_sos.json")
    with open(path, "w") as f:
        json.dump(out, f, indent=1)
        f.write("\n")


if __name__ == "__main__":
    main()
