#!/usr/bin/python3
"""Wall time of the measurements on the emulated board and on the simulator
(the targets: a 10 Hz - 0.4 x rate response with 1 dB accuracy in
<= 20 s on the emulated board and <= 2 s on the simulator; hysteresis loops
at four amplitudes in <= 20 s on the emulated board). Prints figures, asserts
nothing; docs/measurement.md has them with the machine and the date.

The response is the request of check_measure.py (Ahmad2020 stage, 10 Hz -
4 kHz at the 10 kHz loop, 0.09 V peak at a 3 V bias: small enough that the
stage's hysteresis acts as its small-signal slope) with 10 and 40 periods;
the lines within 1 dB and 3 deg of the exact sampled response are counted
(scipy, as check_measure.py computes it), and the board's response is checked
to equal the simulator's bit for bit.

Usage: tools/bench_measure.py [BUILD_ROOT]   (default build/: host/ and fw-qemu-m7/)
"""
import json
import os
import signal as signal_mod
import subprocess
import sys
import tempfile
import time

import numpy as np
from scipy import signal

root = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
build = sys.argv[1] if len(sys.argv) > 1 else os.path.join(root, "build")
exe = os.path.join(build, "host", "host", "piezoloop")
image = os.path.join(build, "fw-qemu-m7", "firmware", "servo.elf")
scenario = os.path.join(root, "configs", "ahmad2020.json")
tmp = tempfile.mkdtemp(prefix="bench_measure_")
BASE = ["--from-hz", "10", "--to-hz", "4000", "--amplitude-v", "0.09", "--bias-v", "3"]


def timed(*args):
    t0 = time.monotonic()
    r = subprocess.run([exe, *args], capture_output=True, text=True)
    if r.returncode != 0:
        sys.exit(f"{' '.join(args[:4])}: {r.stderr}")
    return time.monotonic() - t0


def load(path):
    with open(path) as f:
        return json.load(f)


def lines_within_1db(report):
    """Lines within 1 dB and 3 deg of the exact sampled response (as check_measure.py computes it)."""
    model = load(os.path.join(root, "configs", "models", "ahmad2020_G.json"))
    num = np.array(model["num"]) / model["num"][-1] * model["den"][-1]
    bd, ad, _ = signal.cont2discrete((num, np.array(model["den"])), 1e-4, method="zoh")
    f = np.array(report["frequency_Hz"])
    g = np.array([complex(a, b) for a, b in report["response"]])
    z = np.exp(2j * np.pi * f / 1e4)
    ratio = g / (10.0 * 0.1159 * np.polyval(bd.ravel(), z) / np.polyval(ad, z))
    ok = (np.abs(20 * np.log10(np.abs(ratio))) <= 1.0) & (np.abs(np.angle(ratio, deg=True)) <= 3.0)
    return int(ok.sum()), len(f), float(f[~ok].min()) if (~ok).any() else None


emu = subprocess.Popen([exe, "emulate", "--board", "qemu-m7", "--scenario", scenario, "--image", image],
                       stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
try:
    dev = ["--device", json.loads(emu.stdout.readline())["device"]]
    subprocess.run([exe, *dev, "set", "--scenario", scenario, "--case", "dahl_ff_K"], capture_output=True, check=True)
    b_json, s_json = os.path.join(tmp, "b.json"), os.path.join(tmp, "s.json")
    print("measure frf 10 Hz - 4 kHz, 400 lines, 0.09 V at 3 V, Ahmad2020 stage at 10 kHz, sensor noise on:")
    for periods in (10, 40):
        frf = BASE + ["--periods", str(periods)]
        t_board = timed(*dev, "measure", "frf", *frf, "--restart-stage", "--out", b_json)
        t_sim = timed("measure", "frf", "--scenario", scenario, *frf, "--out", s_json)
        b, s = load(b_json), load(s_json)
        good, n, first_bad = lines_within_1db(b)
        print(f"  {periods} periods (+1 discarded, {(periods + 1) * 0.1:.1f} s of loop time): board (qemu-m7) "
              f"{t_board:5.1f} s wall, simulator {t_sim:5.2f} s wall; board = simulator bit for bit: "
              f"{b['response'] == s['response']}; {good} of {n} lines within 1 dB / 3 deg of the exact response"
              + (f" (the others from {first_bad:.0f} Hz up)" if first_bad else ""))
    print("measure loops, 4 amplitudes (2.5, 5, 7.5, 10 V) x 2 cycles:")
    for f_hz in ("1", "5"):
        loops = ["--amplitudes-v", "2.5,5,7.5,10", "--frequency-hz", f_hz, "--cycles", "2"]
        t_loops = timed(*dev, "measure", "loops", *loops, "--restart-stage", "--out", os.path.join(tmp, "l.csv"))
        t_sim = timed("measure", "loops", "--scenario", scenario, *loops, "--out", os.path.join(tmp, "ls.csv"))
        print(f"  at {f_hz} Hz ({8 / float(f_hz):.1f} s of loop time): board (qemu-m7) {t_loops:5.1f} s wall, "
              f"simulator {t_sim:5.2f} s wall")
finally:
    if emu.poll() is None:
        emu.send_signal(signal_mod.SIGTERM)
        emu.wait(timeout=10)
