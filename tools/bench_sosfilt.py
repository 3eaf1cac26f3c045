#!/usr/bin/python3
"""scipy.signal.sosfilt on the biquad cascade of bench/bench_kernels.cpp.

Prints ns per section per sample for sosfilt filtering one long block (float64
and float32), and, for scale, ns per sample when sosfilt is called once per
sample with its state carried in zi, the way a control tick would have to
call it.

NOT comparable with bench_kernels' figures: those are one sample per call on a
running filter, which is what a control loop does (the input of the next
sample depends on the output of this one). A block filter knows all its input
up front, so it amortises the call over the block and keeps the states in
registers; one sample per call, its per-call overhead (Python, argument
checks, array allocation) dominates by three orders of magnitude. The block
figure is a floor for the arithmetic, the per-call one shows why scipy is not
a candidate for the tick.

Run with Debian's interpreter (numpy/scipy are installed there):
    /usr/bin/python3 tools/bench_sosfilt.py
"""
import math
import platform
import time

import numpy as np
import scipy
from scipy import signal

RATE_HZ = 100_000.0
BLOCK = 1_000_000  # samples per block
REPEATS = 7  # the fastest of these is reported
PER_CALL_SAMPLES = 20_000


def tustin(b, a):
    """One continuous section (descending powers of s) -> discrete sos row."""
    bz, az = signal.bilinear(b, a, fs=RATE_HZ)
    bz = np.concatenate([np.zeros(3 - len(bz)), bz]) if len(bz) < 3 else bz
    az = np.concatenate([az, np.zeros(3 - len(az))]) if len(az) < 3 else az
    return np.concatenate([bz / az[0], az / az[0]])


def sections(count):
    """The reference feedback (reference_stage.hpp) plus a 2.7 kHz notch."""
    w_i, w_r, w_lp, w_hf, w_n = (2 * math.pi * f for f in (0.1, 1e3, 5e3, 20e3, 2.7e3))
    k_i = 235.0
    rows = [
        tustin([k_i * w_hf], [1.0, w_i + w_hf, w_i * w_hf]),
        tustin([1.0, 2 * 0.05 * w_r, w_r**2], [1.0, 2 * 0.7 * w_r, w_r**2]),
        tustin([w_lp**2], [1.0, 2 * 0.7 * w_lp, w_lp**2]),
        tustin([1.0, 2 * 0.05 * w_n, w_n**2], [1.0, 2 * 0.7 * w_n, w_n**2]),
    ]
    return np.array(rows[:count])


def best_seconds(fn):
    """Fastest of REPEATS runs: on a shared machine the slower ones measure
    other processes too (the timeit module's advice)."""
    times = []
    for _ in range(REPEATS):
        t0 = time.perf_counter()
        fn()
        times.append(time.perf_counter() - t0)
    return min(times)


def main():
    rng = np.random.default_rng(1)
    # A tracking-error-like input: a slow triangle of 0.1 um plus noise.
    t = np.arange(BLOCK) / RATE_HZ
    x = 0.1 * signal.sawtooth(2 * math.pi * 10.0 * t, 0.5) + 1e-3 * rng.standard_normal(BLOCK)
    print(f"python {platform.python_version()}, numpy {np.__version__}, scipy {scipy.__version__}")
    print(f"block of {BLOCK} samples, fastest of {REPEATS}:")
    for count in (3, 4):
        for dtype in (np.float64, np.float32):
            sos = sections(count).astype(dtype)
            xb = x.astype(dtype)
            s = best_seconds(lambda: signal.sosfilt(sos, xb))
            print(f"  sosfilt block     {count} sections {np.dtype(dtype).name:7s}: "
                  f"{s * 1e9 / (BLOCK * count):7.2f} ns per section per sample")
    print(f"one sample per call (state in zi), {PER_CALL_SAMPLES} calls, fastest of {REPEATS}:")
    for count in (3, 4):
        sos = sections(count)
        xs = x[:PER_CALL_SAMPLES]

        def per_call():
            zi = np.zeros((count, 2))
            for i in range(PER_CALL_SAMPLES):
                _, zi = signal.sosfilt(sos, xs[i:i + 1], zi=zi)

        s = best_seconds(per_call)
        print(f"  sosfilt per call  {count} sections float64: "
              f"{s * 1e9 / PER_CALL_SAMPLES:9.0f} ns per sample "
              f"({s * 1e9 / (PER_CALL_SAMPLES * count):7.0f} ns per section per sample)")


if __name__ == "__main__":
    main()
