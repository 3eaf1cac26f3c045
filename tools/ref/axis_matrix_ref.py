#!/usr/bin/python3
"""Axis matrices and their products (reference for common/piezoloop/axes/axis_matrix.hpp).
Run with Debian's /usr/bin/python3; writes tests/golden/axis_matrix_ref.json.

Every matrix, offset and float input is a float32 value (what the core holds),
so the products below are of exactly the numbers the core multiplies:
- float: y_i = sum_j M_ij x_j + offset_i, each product exact in float64
  (24 x 24 bits) and summed by math.fsum (correctly rounded);
- Q31: inputs are raw Q31 integers (value raw / 2^31 of each axis's full
  scale); y_i = sum_j c_ij raw_j / 2^31 + offset_i / fs_i in full scales,
  with the sample gains c_ij = M_ij fs_j / fs_i, unsaturated.
cond1 is numpy.linalg.cond(M, 1) (null when numpy finds M singular); valid
says whether the core must accept M: |m| <= 16, ||M||_1 >= 1/16 and
cond1 <= 1000.
"""
import json
import math
import os

import numpy as np

SEED = 20261127
FULL_SCALES = [50.0, 40.0, 100.0]  # each axis's position full scale, µm


def f32(a):
    return np.asarray(a, dtype=np.float32).astype(np.float64)


def cond1(m):
    with np.errstate(all="ignore"):
        try:
            c = float(np.linalg.cond(m, 1))
        except np.linalg.LinAlgError:
            return None
    return c if math.isfinite(c) else None


def is_valid(m, c):
    return bool(np.all(np.abs(m) <= 16.0) and np.linalg.norm(m, 1) >= 1.0 / 16.0 and c is not None and c <= 1000.0)


def with_cond(n, target, rng):
    """A float32 matrix with 1-norm condition number near target: U diag(s) V^T."""
    u, _ = np.linalg.qr(rng.standard_normal((n, n)))
    v, _ = np.linalg.qr(rng.standard_normal((n, n)))
    s = np.geomspace(1.0, 1.0 / target, n)
    m = u @ np.diag(s) @ v.T
    m = m / np.max(np.abs(m)) * 2.0
    m = f32(m)
    # Scale the smallest singular value until the 1-norm condition is near target.
    for _ in range(60):
        c = cond1(m)
        if c is not None and abs(c / target - 1.0) < 0.02:
            break
        s[-1] *= (c / target) if c is not None else 0.5
        m = f32(u @ np.diag(s) @ v.T / np.max(np.abs(u @ np.diag(s) @ v.T)) * 2.0)
    return m


def products(m, offset, rng, n):
    fs = FULL_SCALES[:n]
    floats = []
    xs = [f32(rng.uniform(-100.0, 100.0, n)) for _ in range(6)]
    xs.append(f32(rng.uniform(-1.0e6, 1.0e6, n)))  # the axes' limiters' largest outputs
    xs.append(f32(rng.uniform(-1.0e-3, 1.0e-3, n)))
    for x in xs:
        y = [math.fsum([m[i, j] * x[j] for j in range(n)] + [offset[i]]) for i in range(n)]
        floats.append({"x": [float(v) for v in x], "y": y})
    q31 = []
    raws = [rng.integers(-(2**31), 2**31, n) for _ in range(6)]
    raws.append(np.array([2**31 - 1] * n))
    raws.append(np.array([-(2**31)] * n))
    raws.append(np.array([(-1) ** j * (2**31 - 1) for j in range(n)]))
    raws.append(rng.integers(-1000, 1000, n))
    for raw in raws:
        y = []
        for i in range(n):
            terms = [m[i, j] * fs[j] / fs[i] * float(raw[j]) / 2.0**31 for j in range(n)]
            y.append(math.fsum(terms + [offset[i] / fs[i]]))
        q31.append({"x_raw": [int(v) for v in raw], "y_fs": y})
    return floats, q31


def main():
    rng = np.random.default_rng(SEED)
    matrices = []  # (name, matrix, offset)
    for n in (1, 2, 3):
        matrices.append((f"identity_offsets_{n}", f32(np.eye(n)), f32(rng.uniform(-20.0, 20.0, n))))
        for k in range(4):
            m = f32(np.eye(n) + 0.3 * rng.standard_normal((n, n)))
            matrices.append((f"coupled_{n}_{k}", m, f32(rng.uniform(-50.0, 50.0, n))))
        matrices.append((f"large_{n}", f32(np.clip(8.0 * np.eye(n) + 4.0 * rng.standard_normal((n, n)), -16, 16)),
                         np.zeros(n)))
        matrices.append((f"small_{n}", f32(0.07 * np.eye(n) + 0.001 * rng.standard_normal((n, n))), np.zeros(n)))
    matrices.append(("permutation_3", f32([[0, 1, 0], [0, 0, 1], [1, 0, 0]]), np.zeros(3)))
    matrices.append(("negative_identity_2", f32(-np.eye(2)), np.zeros(2)))
    for n in (2, 3):
        for target, tag in ((900.0, "cond900"), (1100.0, "cond1100"), (1.0e4, "cond1e4")):
            matrices.append((f"{tag}_{n}", with_cond(n, target, rng), np.zeros(n)))
        singular = f32(rng.uniform(-2.0, 2.0, (n, n)))
        singular[-1] = singular[0]
        matrices.append((f"singular_{n}", singular, np.zeros(n)))
    matrices.append(("too_small_1", f32([[0.05]]), np.zeros(1)))
    matrices.append(("too_large_2", f32([[17.0, 0.0], [0.0, 1.0]]), np.zeros(2)))

    cases = []
    for name, m, offset in matrices:
        n = m.shape[0]
        offset = f32(offset)
        c = cond1(m)
        case = {"name": name, "n": n, "matrix": [[float(v) for v in row] for row in m],
                "offset_um": [float(v) for v in offset], "full_scale": FULL_SCALES[:n],
                "cond1": c, "valid": is_valid(m, c)}
        if case["valid"]:
            case["float_products"], case["q31_products"] = products(m, offset, rng, n)
        cases.append(case)
    out = {"seed": SEED, "condition_bound": 1000.0, "cases": cases}
    path = os.path.join(os.path.dirname(__file__), "..", "..", "tests", "golden", "axis_matrix_ref.json")
    with open(path, "w") as f:
        json.dump(out, f, indent=1)
        f.write("\n")


if __name__ == "__main__":
    main()
