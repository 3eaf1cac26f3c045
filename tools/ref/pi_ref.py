#!/usr/bin/python3
"""Reference data for the PI model tests, computed independently of the C++ core.

Forward PI output is evaluated with numpy from the play-operator definition.
The inverse is obtained without the paper's recursion: its thresholds are the
loading curve phi evaluated at the forward thresholds, and its slopes are the
reciprocal slopes of phi measured by finite differences of phi itself; the
weights are the differences of consecutive inverse slopes.
Run with Debian's /usr/bin/python3; writes tests/golden/pi_ref.json.
"""
import json
import os

import numpy as np

# Janaideh2016: 15 play operators, input V, output µm.
R15 = [0.095, 0.38, 0.84, 1.46, 2.21, 3.07, 4.01, 4.98, 5.96, 6.89, 7.76, 8.52, 9.14, 9.61, 9.9]
P15 = [2.55, 0.57, 1.3, -1.57, 1.25, -0.054, -0.032, 0.66, 0.16, -0.77, 2.02, -1.63, -0.15, 2.99, -1.09]
# Janaideh2016 §IV-C numerical example: threshold 0 carries p0.
RNUM = [4.0 * j for j in range(11)]
PNUM = [0.1, 0.0461, 0.069, 0.1029, 0.1535, 0.2291, 0.3417, 0.5098, 0.7605, 1.1345, 1.6925]


def pi_forward(p0, r, p, u):
    w = np.zeros(len(r))
    out = []
    for x in u:
        w = np.maximum(x - np.asarray(r), np.minimum(x + np.asarray(r), w))
        out.append(p0 * x + float(np.dot(p, w)))
    return out


def phi(p0, r, p, x):
    return p0 * x + sum(pj * (x - rj) for rj, pj in zip(r, p) if rj <= x)


def inverse_by_loading_curve(p0, r, p):
    z = [phi(p0, r, p, rj) for rj in r]
    # slopes of phi on each segment, measured from phi itself
    knots = [0.0] + list(r) + [r[-1] + 1.0]
    slopes = [(phi(p0, r, p, b) - phi(p0, r, p, a)) / (b - a) for a, b in zip(knots[:-1], knots[1:])]
    inv_slopes = [1.0 / s for s in slopes]
    g0 = inv_slopes[0]
    g = [inv_slopes[j + 1] - inv_slopes[j] for j in range(len(r))]
    return g0, z, g


def main():
    k = np.arange(2000)
    # decaying sine, +-10 V at first: exercises every threshold and inner loops
    u = (10.0 * np.exp(-k / 1500.0) * np.sin(2 * np.pi * k / 400.0)).tolist()
    # 15-operator set with the "first threshold above zero" rule
    p0 = P15[0]
    r = [x - R15[0] for x in R15[1:]]
    p = P15[1:]
    g0, z, g = inverse_by_loading_curve(p0, r, p)
    # numerical example
    ng0, nz, ng = inverse_by_loading_curve(PNUM[0], RNUM[1:], PNUM[1:])
    data = {
        "set15": {"p0": p0, "thresholds": r, "weights": p, "input": u,
                  "output": pi_forward(p0, r, p, u),
                  "inverse": {"p0": g0, "thresholds": z, "weights": g}},
        "numerical_example": {"p0": PNUM[0], "thresholds": RNUM[1:], "weights": PNUM[1:],
                              "inverse": {"p0": ng0, "thresholds": nz, "weights": ng}},
    }
    out = os.path.join(os.path.dirname(__file__), "..", "..", "tests", "golden", "pi_ref.json")
    with open(out, "w") as f:
        json.dump(data, f, indent=1)
        f.write("\n")


if __name__ == "__main__":
    main()
