#!/usr/bin/python3
"""scipy reference for the float cascade on stiff sections (common/piezoloop/biquad.hpp).

Controllers with poles close to z = 1 at 10-100 kHz, the cases plain float32
direct forms cannot hold:

  ahmad2020_K     Ahmad2020 K(s) (as configs/models/ahmad2020_K.json)
  janaideh2016_C  Janaideh2016 C(s) (as configs/models/janaideh2016_C.json)
  pi_lead         PI-lead: (s + 2 pi 5)(s + 2 pi 100) / ((s + 2 pi 0.02)(s + 2 pi 1000)),
                  a near-integrator with its pole at 0.02 Hz
  notch_50Hz      (s^2 + w^2) / (s^2 + (w / 5) s + w^2), w = 2 pi 50 Hz (Q = 5)

each discretised with Tustin (bilinear_zpk, no prewarping) at 10, 20, 50 and
100 kHz and cut into sections by zpk2sos (pairing 'nearest'). Per case:
the sections, the double-precision frequency response of exactly those
sections (sosfreqz) at log-spaced frequencies from 0.01 Hz to 0.999 Nyquist,
the double-precision impulse response (sosfilt of a unit impulse) at the
first 64 samples and at log-spaced sample indices, and the record length
after which the slowest pole has decayed to 1e-8.

Run with Debian's /usr/bin/python3; writes tests/golden/stiff_sections_ref.json.
"""
import json
import os

import numpy as np
from scipy import signal

RATES_HZ = [1e4, 2e4, 5e4, 1e5]
N_FREQS = 25
DECAY = 1e-8  # impulse record: slowest pole decayed to this fraction


def continuous_models():
    # The models as configs/models/ahmad2020_K.json and janaideh2016_C.json
    # give them (written out here: the golden check runs this script alone).
    zk, pk, kk = signal.tf2zpk([5.29e6, 1.78e10, 1.04e15, 7.66e17, 1.51e22, 4.73e22],
                               [1.0, 4.69e5, 3.21e10, 7.86e14, 7.38e18, 4.71e19, 7.79e19])
    zc = [-7.9e6] + list(np.roots([1.0, 971.0, 4.6e5])) + list(np.roots([1.0, 43.0, 1.4e7]))
    pc = [-8.8e4, -974.0, -1.0] + list(np.roots([1.0, 1153.0, 1.6e7]))
    kc = 0.016
    w = lambda f: 2 * np.pi * f
    wn = w(50.0)
    zn, pn, kn = signal.tf2zpk([1.0, 0.0, wn * wn], [1.0, wn / 5.0, wn * wn])
    return [
        ("ahmad2020_K", "Ahmad2020 K(s)", (zk, pk, kk)),
        ("janaideh2016_C", "Janaideh2016 C(s)", (np.array(zc), np.array(pc), kc)),
        ("pi_lead", "PI-lead, pole at 0.02 Hz",
         (np.array([-w(5.0), -w(100.0)]), np.array([-w(0.02), -w(1000.0)]), 1.0)),
        ("notch_50Hz", "notch at 50 Hz, Q = 5", (zn, pn, kn)),
    ]


def sos_list(sos):
    out = []
    for row in sos:
        assert row[3] == 1.0
        out.append([float(row[0]), float(row[1]), float(row[2]), float(row[4]), float(row[5])])
    return out


def case(name, note, zpk, fs):
    z, p, k = zpk
    zd, pd, kd = signal.bilinear_zpk(z, p, k, fs=fs)
    sos = signal.zpk2sos(zd, pd, kd, pairing="nearest")
    freqs = np.logspace(np.log10(0.01), np.log10(0.999 * fs / 2), N_FREQS)
    _, h = signal.sosfreqz(sos, worN=freqs, fs=fs)
    rho = float(np.max(np.abs(pd)))
    n = int(np.ceil(np.log(DECAY) / np.log(rho))) + 64
    x = np.zeros(n)
    x[0] = 1.0
    imp = signal.sosfilt(sos, x)
    # Rounded, not truncated: a logspace point that is an integer in exact
    # arithmetic may come out a hair below it on another libm.
    idx = sorted(set(list(range(64)) + [int(round(v)) for v in np.logspace(np.log10(64), np.log10(n - 1), 120)]))
    return {"name": name, "note": note, "fs": fs, "sos": sos_list(sos), "slowest_pole_abs": rho,
            "freqs_Hz": [float(v) for v in freqs], "h_re": [float(v) for v in h.real],
            "h_im": [float(v) for v in h.imag], "impulse_samples": n, "impulse_l1": float(np.sum(np.abs(imp))),
            "impulse_index": idx, "impulse": [float(imp[i]) for i in idx]}


def main():
    cases = []
    for name, note, zpk in continuous_models():
        for fs in RATES_HZ:
            cases.append(case(name, note, zpk, fs))
    out = {"decay": DECAY, "cases": cases}
    path = os.path.join(os.path.dirname(os.path.abspath(__file__)), "..", "..", "tests", "golden",
                        "stiff_sections_ref.json")
    with open(path, "w") as f:
        json.dump(out, f, indent=1)
        f.write("\n")


if __name__ == "__main__":
    main()
