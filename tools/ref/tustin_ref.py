#!/usr/bin/python3
"""scipy.signal.bilinear of a few continuous sections (reference for tustin.hpp).
Run with Debian's /usr/bin/python3; writes tests/golden/tustin_ref.json."""
import json
import math
import os

from scipy import signal

CASES = [
    # name, numerator (desc. powers of s), denominator, rate
    ("resonance_1kHz_z0.02", [(2 * math.pi * 1e3) ** 2], [1.0, 2 * 0.02 * 2 * math.pi * 1e3, (2 * math.pi * 1e3) ** 2], 1e5),
    ("resonance_18kHz_z0.05", [(2 * math.pi * 18e3) ** 2], [1.0, 2 * 0.05 * 2 * math.pi * 18e3, (2 * math.pi * 18e3) ** 2], 1e5),
    ("lag_3kHz", [2 * math.pi * 3e3], [1.0, 2 * math.pi * 3e3], 1e5),
    ("general", [2.0, 300.0, 4e6], [1.0, 971.0, 4.6e5], 5e3),
]


def main():
    out = []
    for name, num, den, rate in CASES:
        b, a = signal.bilinear(num, den, fs=rate)
        b = list(b) + [0.0] * (3 - len(b))
        a = list(a) + [0.0] * (3 - len(a))
        n = [0.0] * (3 - len(num)) + list(num)
        d = [0.0] * (3 - len(den)) + list(den)
        out.append({"name": name, "num": n, "den": d, "rate": rate,
                    "b": [float(x) for x in b], "a": [float(x) for x in a]})
    path = os.path.join(os.path.dirname(__file__), "..", "..", "tests", "golden", "tustin_ref.json")
    with open(path, "w") as f:
        json.dump(out, f, indent=1)
        f.write("\n")


if __name__ == "__main__":
    main()
