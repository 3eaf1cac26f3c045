#!/usr/bin/python3
"""Reference for the MIMO frequency response (host/measure/mimo_frf_*,
coupling, static_decoupling): two discrete LTI MIMO systems (2x2 and 3x3),
each element G_ij a second-order section with a lightly damped mode, the
continuous k w^2 / (s^2 + 2 zeta w s + w^2) held by a zero-order hold
(scipy.signal.cont2discrete), couplings 1-5 % of the column's own gain at DC.
For the plan's lines (10 Hz to 2 kHz at 10 kHz: N = 1000, bins 1..200, the
rule of host/measure/frf_plan.hpp) it gives the exact G(e^{jwT}) per line
(scipy.signal.freqz), the coupling per pair and line, its low-frequency
mean over the lowest 3 lines and its largest value, the static gain G0 =
Re(mean of G over the lowest 3 lines), its 1-norm condition
(numpy.linalg.cond), the output matrix D = G0^-1 diag(G0) (numpy.linalg.inv)
and the coupling of G(f) D. Also: a static coupling matrix and its D, an
ill-conditioned one, and one small orthogonal multisine (n = 3, N = 16)
written out from the documented formula.
Run with Debian's /usr/bin/python3; writes tests/golden/mimo_frf_ref.json."""
import json
import math
import os

import numpy as np
from scipy import signal

RATE_HZ = 10000.0
FROM_HZ, TO_HZ = 10.0, 2000.0


def lines(rate, f_from, f_to):
    """The single-axis multisine's rule (frf_plan.hpp, multisine_lines)."""
    n = int(math.floor(rate / f_from + 1e-9))
    k1 = max(1, int(math.ceil(f_from * n / rate - 1e-9)))
    k2 = int(math.floor(f_to * n / rate + 1e-9))
    if 2 * k2 >= n:
        k2 = (n - 1) // 2
    return n, k1, k2


def section(gain, f_hz, zeta):
    w = 2 * math.pi * f_hz
    b, a, _ = signal.cont2discrete(([gain * w * w], [1.0, 2 * zeta * w, w * w]), 1.0 / RATE_HZ, method="zoh")
    return [float(x) for x in np.ravel(b)], [float(x) for x in a]


def system(diag_gain, diag_hz, coupling, coupling_hz):
    """Element (i, j): the diagonal's mode, or a coupling of coupling[i][j]
    times column j's own DC gain with its own mode."""
    n = len(diag_gain)
    elements = []
    for i in range(n):
        row = []
        for j in range(n):
            if i == j:
                b, a = section(diag_gain[i], diag_hz[i], 0.05)
            else:
                b, a = section(coupling[i][j] * diag_gain[j], coupling_hz[i][j], 0.04)
            row.append({"b": b, "a": a})
        elements.append(row)
    return elements


def coupling_figures(f_hz, g):
    """g: lines x n x n. Per off-diagonal pair, row by row."""
    n = g.shape[1]
    out = []
    for i in range(n):
        for j in range(n):
            if i == j:
                continue
            ratio = np.abs(g[:, i, j]) / np.abs(g[:, j, j])
            db = 20 * np.log10(ratio)
            k = int(np.argmax(db))
            out.append({"output": i, "input": j, "coupling_db": [float(x) for x in db],
                        "low_frequency_db": float(20 * np.log10(np.mean(ratio[:3]))),
                        "max_db": float(db[k]), "max_Hz": float(f_hz[k])})
    return out


def case(name, elements):
    n_samples, k1, k2 = lines(RATE_HZ, FROM_HZ, TO_HZ)
    f_hz = np.arange(k1, k2 + 1) * RATE_HZ / n_samples
    n = len(elements)
    g = np.zeros((len(f_hz), n, n), dtype=complex)
    radius = 0.0
    for i in range(n):
        for j in range(n):
            b, a = elements[i][j]["b"], elements[i][j]["a"]
            _, h = signal.freqz(b, a, worN=2 * math.pi * f_hz / RATE_HZ)
            g[:, i, j] = h
            radius = max(radius, float(np.max(np.abs(np.roots(a)))))
    g0 = np.real(np.mean(g[:3], axis=0))
    d = np.linalg.inv(g0) @ np.diag(np.diag(g0))
    gd = g @ d
    return {"name": name, "n": n, "rate_Hz": RATE_HZ, "from_Hz": FROM_HZ, "to_Hz": TO_HZ,
            "period_samples": n_samples, "first_bin": k1, "last_bin": k2, "pole_radius": radius,
            "elements": elements, "frequency_Hz": [float(x) for x in f_hz],
            "response_re": np.real(g).tolist(), "response_im": np.imag(g).tolist(),
            "coupling": coupling_figures(f_hz, g),
            "static_gain": g0.tolist(), "condition_1": float(np.linalg.cond(g0, 1)),
            "output_matrix": d.tolist(), "after": coupling_figures(f_hz, gd)}


def multisine(n_inputs, rate, f_from, f_to):
    """Orthogonal Schroeder multisines (host/measure/mimo_frf_plan.hpp):
    s_lb[t] = sum_k cos(2 pi k t / N + phi_j + 2 pi b l / n), a = 1 / max |s|."""
    n_samples, k1, k2 = lines(rate, f_from, f_to)
    big_k = k2 - k1 + 1
    t = np.arange(n_samples)
    s = np.zeros((n_inputs, n_inputs, n_samples))
    for b in range(n_inputs):
        for l in range(n_inputs):
            for j in range(big_k):
                phi = -math.pi * ((j * (j + 1)) % (2 * big_k)) / big_k
                s[b, l] += np.cos(2 * math.pi * (k1 + j) * t / n_samples + phi + 2 * math.pi * b * l / n_inputs)
    a = 1.0 / np.max(np.abs(s))
    return {"inputs": n_inputs, "rate_Hz": rate, "from_Hz": f_from, "to_Hz": f_to, "amplitude_V": 1.0,
            "line_amplitude_V": float(a), "period": (a * s).tolist()}


def main():
    two = system([1.0, 0.8], [400.0, 550.0], [[0, 0.03], [0.05, 0]], [[0, 480.0], [620.0, 0]])
    three = system([1.0, 0.8, 1.2], [400.0, 550.0, 700.0],
                   [[0, 0.03, -0.01], [0.05, 0, 0.02], [-0.015, 0.04, 0]],
                   [[0, 480.0, 650.0], [620.0, 0, 760.0], [520.0, 840.0, 0]])
    static = np.array([[1.0, 0.04, -0.02], [0.03, 0.9, 0.05], [0.01, -0.03, 1.1]])
    static_d = np.linalg.inv(static) @ np.diag(np.diag(static))
    ill = np.array([[1.0, 0.999], [0.999, 1.0]])
    out = {"cases": [case("2x2", two), case("3x3", three)],
           "static": {"gain": static.tolist(), "condition_1": float(np.linalg.cond(static, 1)),
                      "output_matrix": static_d.tolist()},
           "ill_conditioned": {"gain": ill.tolist(), "condition_1": float(np.linalg.cond(ill, 1))},
           "multisine": multisine(3, 16.0, 1.0, 7.0)}
    path = os.path.join(os.path.dirname(__file__), "..", "..", "tests", "golden", "mimo_frf_ref.json")
    with open(path, "w") as fh:
        json.dump(out, fh)
        fh.write("\n")


if __name__ == "__main__":
    main()
