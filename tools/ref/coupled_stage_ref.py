#!/usr/bin/python3
"""Reference for the coupled-axes stage (common/piezoloop/axes/coupled_stage.hpp,
host/sim/exact_transfer.hpp) on configs/stages/xyz_flexure.json, built here
from the scenario's continuous parameters with scipy alone:

  u_j (V) -> amplifier: gain * Tustin lag w_a / (s + w_a)
          -> hysteresis replaced by a linear gain g_j (below)
          -> dynamics D_j(s): ZOH (cont2discrete of the whole cascade),
             advanced by one sample (y[k] = x(t_{k+1}), the float stage's
             plant step)                                           = x_j
  p_i = x_i + sum over paths j -> i of C_ij(x_j),
        C_ij(s) = dc_gain w^2 / (s^2 + 2 damping w s + w^2), ZOH, advanced
  reading_i / sensor gain = (1 + gain_error) * Tustin lag w_s / (s + w_s) (p_i)

Every block is realised in well-scaled state space (modal second-order
blocks, not scipy's companion form, whose coefficients span 1e17 for the
4th-order dynamics) and discretised with signal.cont2discrete. Quantisers,
clamps, noise, offsets and drift are left out: the linear stage.

g_j is the mean slope of axis j's PI loading curve over the amplifier's
output range: (p0 V + sum_k w_k (V - r_k)) / V at V = output_max_V.

Writes tests/golden/coupled_stage_ref.json:
  (a) G[i][j](e^{j 2 pi f / fs}) from u_j (V) to reading_i / sensor gain (um)
      at 27 log-spaced frequencies from 1 Hz to 0.49 fs and at the modes;
  (b) the first 2000 samples of every reading_i / sensor gain after a step
      of STEP_V on input j (signal.dlsim through the chain), the stage at
      rest before.
Run with Debian's /usr/bin/python3."""
import json
import math
import os

import numpy as np
from scipy import signal

HERE = os.path.dirname(os.path.abspath(__file__))
STAGE = os.path.join(HERE, "..", "..", "configs", "stages", "xyz_flexure.json")
OUT = os.path.join(HERE, "..", "..", "tests", "golden", "coupled_stage_ref.json")
SAMPLES = 2000
STEP_V = 1.0


def second_order(w, zeta, dc):
    """dc w^2 / (s^2 + 2 zeta w s + w^2) as states (position, velocity / w)."""
    a = np.array([[0.0, w], [-w, -2.0 * zeta * w]])
    b = np.array([[0.0], [w * dc]])
    c = np.array([[1.0, 0.0]])
    return a, b, c


def first_order(p):
    """-p / (s - p), p < 0 real: unit DC gain."""
    return np.array([[p]]), np.array([[-p]]), np.array([[1.0]])


def series(blocks):
    """Continuous state space of blocks in series (each SISO, no feedthrough)."""
    n = sum(a.shape[0] for a, _, _ in blocks)
    A = np.zeros((n, n))
    B = np.zeros((n, 1))
    C = np.zeros((1, n))
    k = 0
    prev = None
    for a, b, c in blocks:
        m = a.shape[0]
        A[k:k + m, k:k + m] = a
        if prev is None:
            B[k:k + m, :] = b
        else:
            pk, pm, pc = prev
            A[k:k + m, pk:pk + pm] = b @ pc
        prev = (k, m, c)
        k += m
    pk, pm, pc = prev
    C[:, pk:pk + pm] = pc
    return A, B, C


def zoh_advanced(blocks, ts):
    """ZOH of the series blocks, times z: (Ad, Bd, Cd Ad, Cd Bd)."""
    A, B, C = series(blocks)
    ad, bd, cd, dd, _ = signal.cont2discrete((A, B, C, np.zeros((1, 1))), ts, method="zoh")
    assert not np.any(dd)
    return ad, bd, cd @ ad, cd @ bd


def tustin_lag(f_hz, gain, ts):
    """gain * w / (s + w) by the bilinear transform (gain alone for f = 0)."""
    if f_hz == 0.0:
        return np.zeros((0, 0)), np.zeros((0, 1)), np.zeros((1, 0)), np.array([[gain]])
    w = 2.0 * math.pi * f_hz
    ad, bd, cd, dd, _ = signal.cont2discrete((np.array([[-w]]), np.array([[w]]), np.array([[gain]]), np.zeros((1, 1))),
                                             ts, method="bilinear")
    return ad, bd, cd, dd


def dynamics_blocks(dyn):
    model = dyn["model"]
    assert not model["zeros"] and dyn.get("normalise_dc", False) and dyn.get("discretisation", "zoh") == "zoh"
    poles = [complex(p[0], p[1]) for p in model["poles"]]
    blocks = []
    for p in poles:
        if p.imag > 0.0:
            w = abs(p)
            blocks.append(second_order(w, -p.real / w, 1.0))
        elif p.imag == 0.0:
            blocks.append(first_order(p.real))
    return blocks  # unit DC gain each, so the cascade's is 1 (normalise_dc)


def mean_slope(h, v_max):
    assert h["kind"] == "pi"
    s = h["p0_um_per_V"] * v_max
    for r, w in zip(h["thresholds_V"], h["weights_um_per_V"]):
        s += w * max(v_max - r, 0.0)
    return s / v_max


def freq(sys, z):
    a, b, c, d = sys
    if a.shape[0] == 0:
        return complex(d[0, 0])
    return complex((c @ np.linalg.solve(z * np.eye(a.shape[0]) - a, b) + d)[0, 0])


def simulate(sys, u):
    a, b, c, d = sys
    if a.shape[0] == 0:
        return d[0, 0] * u
    _, y, _ = signal.dlsim((a, b, c, d, 1.0), u)
    return y[:, 0]


def main():
    with open(STAGE) as f:
        stage = json.load(f)
    fs = float(stage["loop"]["rate_Hz"])
    ts = 1.0 / fs
    axes = stage["plant"]["axes"]
    names = [a["name"] for a in axes]
    n = len(axes)
    amp, plant, gain, sens = [], [], [], []
    for a in axes:
        amp.append(tustin_lag(a["amplifier"].get("bandwidth_Hz", 0.0), a["amplifier"]["gain"], ts))
        plant.append(zoh_advanced(dynamics_blocks(a["dynamics"]), ts))
        gain.append(mean_slope(a["hysteresis"], a["amplifier"]["output_max_V"]))
        sens.append(tustin_lag(a["sensor"].get("bandwidth_Hz", 0.0), 1.0 + a["sensor"].get("gain_error", 0.0), ts))
    paths = []  # (from, to, system)
    for c in stage["plant"]["coupling"]:
        w = 2.0 * math.pi * c["mode_Hz"]
        assert c.get("discretisation", "zoh") == "zoh" and c["damping"] < 1.0
        paths.append((names.index(c["from"]), names.index(c["to"]),
                      zoh_advanced([second_order(w, c["damping"], c["dc_gain"])], ts)))

    modes = sorted({float(m) for m in (750, 850, 3200, 3600, 4000)})
    freqs = sorted([float(f) for f in np.logspace(0.0, math.log10(0.49 * fs), 27)] + modes)
    matrices = []
    for f_hz in freqs:
        z = np.exp(1j * 2.0 * math.pi * f_hz / fs)
        g = [[0j] * n for _ in range(n)]
        for j in range(n):
            xj = freq(amp[j], z) * gain[j] * freq(plant[j], z)
            for i in range(n):
                path = (1.0 if i == j else 0.0) + sum(freq(s, z) for fr, to, s in paths if fr == j and to == i)
                g[i][j] = freq(sens[i], z) * path * xj
        matrices.append([[[v.real, v.imag] for v in row] for row in g])

    steps = []
    for j in range(n):
        u = np.full(SAMPLES, STEP_V)
        xj = gain[j] * simulate(plant[j], simulate(amp[j], u))
        out = []
        for i in range(n):
            p = xj.copy() if i == j else np.zeros(SAMPLES)
            for fr, to, s in paths:
                if fr == j and to == i:
                    p = p + simulate(s, xj)
            y = simulate(sens[i], p)
            out.append([float(f"{v:.12g}") for v in y])
        steps.append(out)

    result = {
        "stage": "configs/stages/xyz_flexure.json",
        "rate_Hz": fs,
        "axes": names,
        "linear_gain_um_per_V": gain,
        "frequencies_Hz": freqs,
        "transfer": matrices,
        "step_V": STEP_V,
        "step_samples": SAMPLES,
        "steps": steps,
    }
    with open(OUT, "w") as f:
        json.dump(result, f, indent=None, separators=(",", ":"))
        f.write("\n")


if __name__ == "__main__":
    main()
