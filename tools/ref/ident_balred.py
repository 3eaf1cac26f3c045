#!/usr/bin/python3
"""Reference Hankel singular values and balanced truncations (for
host/ident/balred.hpp), computed with scipy independently of the C++ code.

Models (state-space matrices are stored, so the C++ test needs no
conversion code):
  - janaideh_D: Janaideh2016's normalised D(s) (eq. 60; 8th order,
    right-half-plane zeros), realised as a cascade of four sections each
    frequency-scaled by its natural frequency (a companion form of the full
    polynomial would have coefficients up to 1e32).
  - random9: a 9th-order random stable model (numpy seed 9), modal form
    mixed by a random orthogonal similarity.
  - random9_zoh: random9 discretised by scipy.signal.cont2discrete (ZOH) at a
    rate of 20 times its fastest pole magnitude, for the discrete Lyapunov path.

Gramians: scipy.linalg.solve_continuous_lyapunov / solve_discrete_lyapunov;
HSVs: sqrt(eig(P Q)). Reduced models: square-root balanced truncation
written here with scipy.linalg (cholesky of P + tiny shift is avoided: the
factors come from eigh), stored as their frequency responses at a few
points, which do not depend on the state coordinates.
Run with Debian's /usr/bin/python3; writes tests/golden/ident_balred.json.
"""
import json
import os

import numpy as np
from scipy import linalg, signal


def series(sections):
    """Cascade of (A, B, C, D) sections, the first one sees the input."""
    A, B, C, D = sections[0]
    for A2, B2, C2, D2 in sections[1:]:
        n1, n2 = A.shape[0], A2.shape[0]
        A = np.block([[A, np.zeros((n1, n2))], [B2 @ C, A2]])
        B = np.vstack([B, B2 * D])
        C = np.hstack([D2 * C, C2])
        D = D2 * D
    return A, B, C, D


def scaled_section(num, den):
    """num/den in s (den monic, degree 1 or 2), realised on s = w s~ with
    w = den[-1]**(1/deg) so the section's own coefficients are O(1)."""
    num = np.atleast_1d(np.asarray(num, float))
    den = np.asarray(den, float)
    deg = len(den) - 1
    w = den[-1] ** (1.0 / deg)
    # H~(s~) = H(w s~): coefficient of s~^k is c_k w^k.
    nn = num * w ** np.arange(len(num) - 1, -1, -1)
    dd = den * w ** np.arange(deg, -1, -1)
    nn, dd = nn / dd[0], dd / dd[0]
    At, Bt, Ct, Dt = signal.tf2ss(nn, dd)
    return w * At, w * Bt, Ct, Dt


def janaideh_D():
    # D(s) = -20.7 (s-1.22e5)(s+2.99e4)(s-2.776e4)(s-1.07e4)(s+1430)(s^2+4.3e4 s+3.2e9)
    #        / [(s^2+925s+4.59e5)(s^2+55s+1.4e7)(s^2+1.54e4 s+4e9)(s^2+964s+3.95e9)]
    secs = [
        ([1.0, 1430.0], [1.0, 925.0, 4.59e5]),
        (np.polymul([1.0, -2.776e4], [1.0, -1.07e4]), [1.0, 55.0, 1.4e7]),
        ([1.0, 4.3e4, 3.2e9], [1.0, 1.54e4, 4e9]),
        (np.polymul([1.0, -1.22e5], [1.0, 2.99e4]), [1.0, 964.0, 3.95e9]),
    ]
    parts = [scaled_section(n, d) for n, d in secs]
    A, B, C, D = series(parts)
    C = -20.7 * C
    D = -20.7 * D
    return A, B, C, D


def random9():
    rng = np.random.default_rng(9)
    blocks = []
    for _ in range(4):
        wn = 10.0 ** rng.uniform(0.0, 3.0)
        zeta = rng.uniform(0.05, 0.7)
        blocks.append(np.array([[-zeta * wn, wn * np.sqrt(1 - zeta ** 2)],
                                [-wn * np.sqrt(1 - zeta ** 2), -zeta * wn]]))
    blocks.append(np.array([[-10.0 ** rng.uniform(0.0, 3.0)]]))
    Am = linalg.block_diag(*blocks)
    Bm = rng.standard_normal((9, 1))
    Cm = rng.standard_normal((1, 9))
    Q, _ = np.linalg.qr(rng.standard_normal((9, 9)))
    return Q @ Am @ Q.T, Q @ Bm, Cm @ Q.T, np.array([[rng.standard_normal()]])


def gramians(A, B, C, discrete):
    if discrete:
        P = linalg.solve_discrete_lyapunov(A, B @ B.T)
        Q = linalg.solve_discrete_lyapunov(A.T, C.T @ C)
    else:
        P = linalg.solve_continuous_lyapunov(A, -B @ B.T)
        Q = linalg.solve_continuous_lyapunov(A.T, -C.T @ C)
    return (P + P.T) / 2, (Q + Q.T) / 2


def factor(X):
    w, V = linalg.eigh(X)
    return V * np.sqrt(np.maximum(w, 0.0))


def balred(A, B, C, D, order, discrete):
    P, Q = gramians(A, B, C, discrete)
    Lp, Lq = factor(P), factor(Q)
    U, s, Vt = linalg.svd(Lq.T @ Lp)
    S1 = np.diag(1.0 / np.sqrt(s[:order]))
    Tl = S1 @ U[:, :order].T @ Lq.T
    Tr = Lp @ Vt[:order, :].T @ S1
    return Tl @ A @ Tr, Tl @ B, C @ Tr, D


def freqresp(A, B, C, D, points):
    n = A.shape[0]
    return [complex((C @ np.linalg.solve(p * np.eye(n) - A, B) + D)[0, 0]) for p in points]


def case(name, A, B, C, D, orders, ts):
    discrete = ts > 0
    P, Q = gramians(A, B, C, discrete)
    hsv = np.sqrt(np.abs(np.sort(linalg.eigvals(P @ Q).real)[::-1]))
    poles = linalg.eigvals(A)
    if discrete:
        w = np.linspace(0.0, np.pi / ts, 7)[1:-1]
        points = np.exp(1j * w * ts)
    else:
        mags = np.abs(poles)
        w = np.geomspace(mags.min() / 10, mags.max() * 10, 9)
        points = 1j * w
    reduced = []
    for r in orders:
        Ar, Br, Cr, Dr = balred(A, B, C, D, r, discrete)
        h = freqresp(Ar, Br, Cr, Dr, points)
        reduced.append({"order": r, "bound": float(2 * np.sum(hsv[r:])),
                        "re": [z.real for z in h], "im": [z.imag for z in h]})
    return {"name": name, "ts": ts,
            "A": A.tolist(), "B": B[:, 0].tolist(), "C": C[0, :].tolist(), "D": float(D[0, 0]),
            "hsv": hsv.tolist(), "omega": w.tolist(), "reduced": reduced}


def main():
    cases = []
    A, B, C, D = janaideh_D()
    cases.append(case("janaideh_D", A, B, C, D, [4, 6], 0.0))
    A, B, C, D = random9()
    cases.append(case("random9", A, B, C, D, [3, 5], 0.0))
    fastest = np.abs(linalg.eigvals(A)).max()
    ts = 2 * np.pi / (20 * fastest)
    Ad, Bd, Cd, Dd, _ = signal.cont2discrete((A, B, C, D), ts, method="zoh")
    cases.append(case("random9_zoh", Ad, Bd, Cd, Dd, [3, 5], float(ts)))
    path = os.path.join(os.path.dirname(__file__), "..", "..", "tests", "golden", "ident_balred.json")
    with open(path, "w") as f:
        json.dump({"cases": cases}, f, indent=1)
        f.write("\n")


if __name__ == "__main__":
    main()
