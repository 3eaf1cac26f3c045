#!/usr/bin/python3
"""scipy.signal.welch of a record like the scope's (reference for host/ui/psd.hpp).
Hann window, half overlap, mean removed per segment, one-sided density: the
defaults of scipy.signal.welch. The input is float32, as the board's samples.
Run with Debian's /usr/bin/python3; writes tests/golden/ui_welch.json."""
import json
import math
import os

import numpy as np
from scipy import signal

RATE_HZ = 10000.0


def record(n):
    """Two tones, an offset and a deterministic pseudo-random noise (an LCG, so
    the input does not depend on numpy's generators)."""
    state = 12345
    out = []
    for i in range(n):
        state = (1103515245 * state + 12345) % 2**31
        noise = state / 2**31 - 0.5
        t = i / RATE_HZ
        out.append(1.5 + 2.0 * math.sin(2 * math.pi * 440.0 * t) + 0.3 * math.sin(2 * math.pi * 2712.5 * t + 0.4)
                   + 0.05 * noise)
    return np.array(out, dtype=np.float32)


def main():
    cases = []
    for n, segment in [(4096, 512), (3000, 256), (1000, 1024)]:
        x = record(n)
        nperseg = min(segment, n)
        f, p = signal.welch(x.astype(np.float64), fs=RATE_HZ, nperseg=nperseg)
        cases.append({"rate_Hz": RATE_HZ, "segment": segment, "x": [float(v) for v in x],
                      "frequency_Hz": [float(v) for v in f], "psd": [float(v) for v in p]})
    path = os.path.join(os.path.dirname(__file__), "..", "..", "tests", "golden", "ui_welch.json")
    with open(path, "w") as fh:
        json.dump(cases, fh)
        fh.write("\n")


if __name__ == "__main__":
    main()
