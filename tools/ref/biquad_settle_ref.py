#!/usr/bin/python3
"""scipy reference for BiquadCascade::settle (common/piezoloop/biquad.hpp):
the DC steady state of a biquad cascade under a constant input.

For each cascade (rows b0 b1 b2 a1 a2, a0 = 1):
- zi: scipy.signal.sosfilt_zi, the transposed direct form II states of every
  section at rest under a unit input (scaled by the DC gain of the sections
  before it), i.e. the states DF2T holds for x = 1;
- node_gain: the DC gain from the input to each section's output,
  prod_j<=i (b0 + b1 + b2) / (1 + a1 + a2), from the polynomials;
- steady: the output after 400 000 samples of a unit input from rest
  (sosfilt), an independent check of H(1) = node_gain[-1].

Cascades: pre-filters as the commissioning designs them (a notch at a mode
and a low-pass, Tustin), one with poles near z = 1 (the delta form's case),
one with DC gain 0 (a high-pass) and one with DC gain 0.8.

Run with Debian's /usr/bin/python3; writes tests/golden/biquad_settle_ref.json.
"""
import json
import os

import numpy as np
from scipy import signal


def tustin_sos(num, den, fs):
    z, p, k = signal.tf2zpk(num, den)
    zd, pd, kd = signal.bilinear_zpk(z, p, k, fs)
    return signal.zpk2sos(zd, pd, kd, pairing="nearest")


def notch(f_Hz, zeta_z, zeta_p):
    w = 2 * np.pi * f_Hz
    return [1.0, 2 * zeta_z * w, w * w], [1.0, 2 * zeta_p * w, w * w]


def lowpass(f_Hz, zeta, gain=1.0):
    w = 2 * np.pi * f_Hz
    return [gain * w * w], [1.0, 2 * zeta * w, w * w]


def cascade(sections, fs):
    return np.vstack([tustin_sos(n, d, fs) for n, d in sections])


def case(name, sos, fs, note):
    zi = signal.sosfilt_zi(sos)
    gains = []
    g = 1.0
    for row in sos:
        g *= (row[0] + row[1] + row[2]) / (row[3] + row[4] + row[5])
        gains.append(float(g))
    y = signal.sosfilt(sos, np.ones(400000))
    # From zi the output is the steady one from the first sample on.
    y_zi, _ = signal.sosfilt(sos, np.ones(50), zi=zi)
    assert np.max(np.abs(y_zi - gains[-1])) <= 1e-9 * max(1.0, abs(gains[-1]))
    return {"name": name, "note": note, "rate_Hz": fs,
            "sos": [[float(r[0]), float(r[1]), float(r[2]), float(r[4]), float(r[5])] for r in sos],
            "zi": [[float(v) for v in z] for z in zi], "node_gain": gains, "steady": float(y[-1])}


cases = [
    case("notch_lowpass_10k", cascade([notch(1000.0, 0.02, 0.5), lowpass(2000.0, 0.7)], 10000.0), 10000.0,
         "notch at a 1 kHz mode and a 2 kHz low-pass, 10 kHz loop: direct form II transposed in float"),
    case("lowpass_near_z1_100k", cascade([lowpass(100.0, 0.7), notch(300.0, 0.05, 0.7)], 100000.0), 100000.0,
         "100 Hz low-pass and a 300 Hz notch at 100 kHz: poles near z = 1, the delta form in float"),
    case("highpass_10k", cascade([([1.0, 0.0, 0.0], [1.0, 2 * 0.7 * 2 * np.pi * 50.0, (2 * np.pi * 50.0) ** 2])],
                                 10000.0), 10000.0, "a 50 Hz high-pass: DC gain 0"),
    case("gain_0p8_10k", cascade([lowpass(500.0, 0.5, 0.8)], 10000.0), 10000.0, "a 500 Hz low-pass of DC gain 0.8"),
]

out = os.path.join(os.path.dirname(os.path.abspath(__file__)), "..", "..", "tests", "golden",
                   "biquad_settle_ref.json")
with open(out, "w") as f:
    json.dump({"generator": "tools/ref/biquad_settle_ref.py", "cases": cases}, f, indent=1)
    f.write("\n")
