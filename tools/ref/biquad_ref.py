#!/usr/bin/python3
"""scipy reference for the biquad cascade (common/piezoloop/biquad.hpp).

(a) A few well-conditioned filters at 100 kHz as SOS, with their impulse
    responses (sosfilt of a unit impulse) and frequency responses (sosfreqz).
(b) The Ahmad2020 controller K(s) (Ahmad2020 eq. 24) discretised at 100 kHz with
    Tustin (tf2zpk -> bilinear_zpk -> zpk2sos, pairing 'nearest'), its
    double-precision frequency response and step response (sosfilt, float64).

Run with Debian's /usr/bin/python3; writes tests/golden/biquad_ref.json.
"""
import json
import os

import numpy as np
from scipy import signal

FS = 1e5
IMPULSE_SAMPLES = 200
FREQS_HZ = [10.0, 100.0, 1e3, 5e3, 1e4, 2e4, 4e4]


def sos_list(sos):
    # zpk2sos/butter rows are [b0 b1 b2 a0 a1 a2] with a0 = 1.
    out = []
    for row in sos:
        assert row[3] == 1.0
        out.append([float(row[0]), float(row[1]), float(row[2]), float(row[4]), float(row[5])])
    return out


def freq_response(sos, freqs):
    _, h = signal.sosfreqz(sos, worN=np.asarray(freqs), fs=FS)
    return [float(v) for v in h.real], [float(v) for v in h.imag]


def filter_case(name, sos, note):
    x = np.zeros(IMPULSE_SAMPLES)
    x[0] = 1.0
    h = signal.sosfilt(sos, x)
    # L1 norm of the (long) impulse response: bounds the output for |x| <= 1.
    long_x = np.zeros(200000)
    long_x[0] = 1.0
    l1 = float(np.sum(np.abs(signal.sosfilt(sos, long_x))))
    re, im = freq_response(sos, FREQS_HZ)
    return {"name": name, "note": note, "sos": sos_list(sos), "impulse": [float(v) for v in h],
            "impulse_l1": l1, "freqs_Hz": FREQS_HZ, "h_re": re, "h_im": im}


def resonance_sos(f0, zeta):
    w = 2 * np.pi * f0
    b, a = signal.bilinear([w * w], [1.0, 2 * zeta * w, w * w], fs=FS)
    return signal.tf2sos(b, a)


def ahmad2020_k():
    # Ahmad2020 eq. 24: numerator n5..n0, monic denominator with d5..d0.
    num = [5.29e6, 1.78e10, 1.04e15, 7.66e17, 1.51e22, 4.73e22]
    den = [1.0, 4.69e5, 3.21e10, 7.86e14, 7.38e18, 4.71e19, 7.79e19]
    z, p, k = signal.tf2zpk(num, den)
    zd, pd, kd = signal.bilinear_zpk(z, p, k, fs=FS)
    sos = signal.zpk2sos(zd, pd, kd, pairing="nearest")
    freqs = [1.0, 10.0, 100.0, 1e3, 1e4, 4e4]
    re, im = freq_response(sos, freqs)
    n_step = 200001
    step = signal.sosfilt(sos, np.ones(n_step))
    # Step response: every sample of the first 100, then every 1000th.
    idx = list(range(100)) + list(range(100, n_step, 1000))
    # Largest partial-cascade gain (L1 of the impulse response), to choose Q31 scales.
    imp = np.zeros(n_step)
    imp[0] = 1.0
    partial_l1 = [float(np.sum(np.abs(signal.sosfilt(sos[:i + 1], imp)))) for i in range(len(sos))]
    return {"num": num, "den": den, "fs": FS, "dc_gain": num[-1] / den[-1], "sos": sos_list(sos),
            "freqs_Hz": freqs, "h_re": re, "h_im": im,
            "step_index": idx, "step": [float(step[i]) for i in idx], "partial_l1": partial_l1}


def main():
    b, a = signal.iirnotch(18e3, 10.0, fs=FS)
    cases = [
        filter_case("butter2_lp_1kHz", signal.butter(2, 1e3, fs=FS, output="sos"),
                    "butter(2, 1 kHz) low-pass"),
        filter_case("butter4_lp_5kHz", signal.butter(4, 5e3, fs=FS, output="sos"),
                    "butter(4, 5 kHz) low-pass, two sections"),
        filter_case("notch_18kHz_Q10", signal.tf2sos(b, a), "iirnotch(18 kHz, Q = 10)"),
        filter_case("resonance_18kHz_z0.05", resonance_sos(18e3, 0.05),
                    "Tustin of w^2 / (s^2 + 2 0.05 w s + w^2), w = 2 pi 18 kHz (Shan2012-like resonance)"),
    ]
    out = {"fs": FS, "filters": cases, "ahmad2020_k": ahmad2020_k()}
    path = os.path.join(os.path.dirname(os.path.abspath(__file__)), "..", "..", "tests", "golden", "biquad_ref.json")
    with open(path, "w") as f:
        json.dump(out, f, indent=1)
        f.write("\n")


if __name__ == "__main__":
    main()
