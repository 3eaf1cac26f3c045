#!/usr/bin/python3
"""Reference data for RLS / ARX identification (host/ident/rls.hpp),
computed with numpy independently of the C++ code.

System (Ljung's classic second-order example, as an ARX model with delay 1):
    y[k] - 1.5 y[k-1] + 0.7 y[k-2] = 1.0 u[k-1] + 0.5 u[k-2] + e[k]
u: a seeded random binary sequence (+-1, held 1..3 samples), e: seeded
Gaussian noise with sigma 0.1. 1000 samples, ts = 1e-4 s.
Reference: the batch least-squares ARX estimate (numpy.linalg.lstsq on the
regressors [-y[k-1], -y[k-2], u[k-1], u[k-2]] for k >= 2), which RLS with no
forgetting reproduces up to its prior.
Run with Debian's /usr/bin/python3; writes tests/golden/ident_rls.json.
"""
import json
import os

import numpy as np

A = [1.0, -1.5, 0.7]
B = [1.0, 0.5]  # b0 u[k-1] + b1 u[k-2]
SIGMA = 0.1


def main():
    rng = np.random.default_rng(1991)
    n = 1000
    u = np.zeros(n)
    k = 0
    while k < n:
        hold = int(rng.integers(1, 4))
        u[k:k + hold] = 1.0 if rng.random() < 0.5 else -1.0
        k += hold
    e = SIGMA * rng.standard_normal(n)
    y = np.zeros(n)
    for k in range(n):
        v = e[k]
        if k >= 1:
            v += -A[1] * y[k - 1] + B[0] * u[k - 1]
        if k >= 2:
            v += -A[2] * y[k - 2] + B[1] * u[k - 2]
        y[k] = v
    phi = np.column_stack([-y[1:-1], -y[:-2], u[1:-1], u[:-2]])
    theta = np.linalg.lstsq(phi, y[2:], rcond=None)[0]
    ts = 1e-4
    data = {"ts": ts, "t": (ts * np.arange(n)).tolist(), "u": u.tolist(), "y": y.tolist(),
            "true": {"a": A[1:], "b": B, "delay": 1, "noise_sigma": SIGMA},
            "lstsq": {"a": theta[:2].tolist(), "b": theta[2:].tolist()}}
    path = os.path.join(os.path.dirname(__file__), "..", "..", "tests", "golden", "ident_rls.json")
    with open(path, "w") as f:
        json.dump(data, f, indent=1)
        f.write("\n")


if __name__ == "__main__":
    main()
