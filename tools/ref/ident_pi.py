#!/usr/bin/python3
"""Reference data for the PI weight fit (host/ident/pi_fit.hpp), computed
with numpy/scipy independently of the C++ code.

Data (inputs and noisy outputs rounded to 1e-6, as a data file holds
them; references computed from the rounded values): play operators evaluated from their definition (w = 0 before the first
sample) on an input whose amplitude ramps up to ~10.2 (envelope 11) and then decays, so
every threshold is reached and the reversals make nested inner loops.
Cases:
  - set15: Janaideh2016's 15-operator set (first operator taken
    as the linear term), negative weights included, with seeded Gaussian
    noise (sigma 0.01 µm). Reference: numpy.linalg.lstsq on the play regressors.
  - nonmonotone: p0 and 8 operators on the uniform grid r_j = j * (max|u| / 9),
    weights chosen so the loading curve slope P_3 < 0 (not invertible),
    sigma 0.01 noise. References: lstsq (unconstrained) and the monotone fit
    min |Phi p - y| s.t. every slope P_j >= 0.05, solved by scipy.optimize.nnls
    on the slope parametrisation p = D P (D the first-difference matrix).
  - shan: Shan2012's grid gamma_j = rho j (rho = 0.1079, j = 1..8) and density
    weights lambda exp(-delta gamma_j) (lambda 0.0211, delta -5.0194) with
    p0 = 0.8331, input amplitude 1, no noise: the fit must return the weights.
Run with Debian's /usr/bin/python3; writes tests/golden/ident_pi.json.
"""
import json
import math
import os

import numpy as np
from scipy import optimize

R15 = [0.095, 0.38, 0.84, 1.46, 2.21, 3.07, 4.01, 4.98, 5.96, 6.89, 7.76, 8.52, 9.14, 9.61, 9.9]
P15 = [2.55, 0.57, 1.3, -1.57, 1.25, -0.054, -0.032, 0.66, 0.16, -0.77, 2.02, -1.63, -0.15, 2.99, -1.09]


def plays(u, thresholds):
    w = np.zeros(len(thresholds))
    r = np.asarray(thresholds)
    out = np.zeros((len(u), len(thresholds)))
    for k, x in enumerate(u):
        w = np.maximum(x - r, np.minimum(x + r, w))
        out[k] = w
    return out


def regressors(u, thresholds):
    return np.column_stack([np.asarray(u), plays(u, thresholds)])


def excitation(n, peak):
    k = np.arange(n)
    env = peak * np.minimum(1.0, k / 600.0) * np.exp(-np.maximum(0.0, k - 600.0) / 1000.0)
    # Rounded to 1e-6 (as a data file would hold it): the stored values are
    # exactly the input the outputs were computed from.
    return np.round(env * np.sin(2 * np.pi * k / 300.0), 6)


def main():
    rng = np.random.default_rng(2016)
    n = 3000
    u = excitation(n, 11.0)

    # set15
    r15 = [x - R15[0] for x in R15[1:]]
    w15 = np.array(P15)
    phi = regressors(u, r15)
    y15 = np.round(phi @ w15 + 0.01 * rng.standard_normal(n), 6)
    ls15 = np.linalg.lstsq(phi, y15, rcond=None)[0]

    # nonmonotone, uniform grid of 8 operators
    reach = float(np.max(np.abs(u)))
    step = reach / 9
    rg = [step * j for j in range(1, 9)]
    wg = np.array([1.0, 0.5, -0.8, -0.9, 0.6, 0.3, -0.2, 0.4, 0.1])
    phig = regressors(u, rg)
    yg = np.round(phig @ wg + 0.01 * rng.standard_normal(n), 6)
    lsg = np.linalg.lstsq(phig, yg, rcond=None)[0]
    m = 0.05
    D = np.eye(9) - np.eye(9, k=-1)
    psi = phig @ D
    Pp, _ = optimize.nnls(psi, yg - m * psi.sum(axis=1), maxiter=1000)
    slopes = m + Pp
    mono = D @ slopes

    # Shan2012 grid and density
    rho, lam, delta, g0 = 0.1079, 0.0211, -5.0194, 0.8331
    us = excitation(n, 1.0)
    rs = [rho * j for j in range(1, 9)]
    ws = [g0] + [lam * math.exp(-delta * g) for g in rs]
    ys = regressors(us, rs) @ np.array(ws)

    data = {
        "u": u.tolist(),
        "set15": {"thresholds": r15, "weights": w15.tolist(), "noise_sigma": 0.01,
                  "y": y15.tolist(), "lstsq": ls15.tolist()},
        "nonmonotone": {"operators": 8, "thresholds": rg, "weights": wg.tolist(), "noise_sigma": 0.01,
                        "y": yg.tolist(), "lstsq": lsg.tolist(), "min_slope": m,
                        "monotone": mono.tolist(), "monotone_slopes": slopes.tolist()},
        "shan": {"rho": rho, "thresholds": rs, "weights": ws, "u": us.tolist(), "y": ys.tolist()},
    }
    path = os.path.join(os.path.dirname(__file__), "..", "..", "tests", "golden", "ident_pi.json")
    with open(path, "w") as f:
        json.dump(data, f, indent=1)
        f.write("\n")


if __name__ == "__main__":
    main()
