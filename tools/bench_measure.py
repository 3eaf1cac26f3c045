#!/usr/bin/python3
"""Wall time of the measurements on the emulated board and on the simulator
(issue 16's targets: a 10 Hz - 0.4 x rate response with 1 dB accuracy in
<= 20 s on the emulated board and <= 2 s on the simulator; hysteresis loops
at four amplitudes in <= 20 s on the emulated board). Prints figures, asserts
nothing; docs/measurement.md has them with the machine and the date.

The response is the request of check_measure.py (Ahmad2020 stage, 10 Hz -
4 kHz at the 10 kHz loop, 0.09 V peak at a 3 V bias, 40 periods), whose
accuracy against the exact sampled response that test proves (0.5 dB, 3 deg);
on the board it is checked to be that same response, bit for bit, so the
accuracy holds there too. Also the largest standard deviation of a line.

Usage: tools/bench_measure.py [BUILD_ROOT]   (default build/: host/ and fw-qemu-m7/)
"""
import json
import os
import signal
import subprocess
import sys
import tempfile
import time

root = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
build = sys.argv[1] if len(sys.argv) > 1 else os.path.join(root, "build")
exe = os.path.join(build, "host", "host", "piezoloop")
image = os.path.join(build, "fw-qemu-m7", "firmware", "servo.elf")
scenario = os.path.join(root, "configs", "ahmad2020.json")
tmp = tempfile.mkdtemp(prefix="bench_measure_")
frf = ["--from-hz", "10", "--to-hz", "4000", "--amplitude-v", "0.09", "--bias-v", "3", "--periods", "40"]
loops = ["--amplitudes-v", "2.5,5,7.5,10", "--frequency-hz", "1", "--cycles", "2"]


def timed(*args):
    t0 = time.monotonic()
    r = subprocess.run([exe, *args], capture_output=True, text=True)
    if r.returncode != 0:
        sys.exit(f"{' '.join(args[:4])}: {r.stderr}")
    return time.monotonic() - t0


def load(path):
    with open(path) as f:
        return json.load(f)


emu = subprocess.Popen([exe, "emulate", "--board", "qemu-m7", "--scenario", scenario, "--image", image],
                       stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
try:
    dev = ["--device", json.loads(emu.stdout.readline())["device"]]
    subprocess.run([exe, *dev, "set", "--scenario", scenario, "--case", "dahl_ff_K"], capture_output=True, check=True)
    b_json, s_json = os.path.join(tmp, "b.json"), os.path.join(tmp, "s.json")
    t_board = timed(*dev, "measure", "frf", *frf, "--restart-stage", "--out", b_json)
    t_sim = timed("measure", "frf", "--scenario", scenario, *frf, "--out", s_json)
    b, s = load(b_json), load(s_json)
    same = b["response"] == s["response"]
    worst_std = max(x for x in b["std_db"] if x is not None)
    device_s = 41 * 1000 / 10000
    print(f"measure frf 10 Hz - 4 kHz (400 lines, 41 periods = {device_s:.1f} s at 10 kHz):")
    print(f"  emulated board (qemu-m7): {t_board:6.2f} s wall; the simulator's response bit for bit: {same}")
    print(f"  simulator:                {t_sim:6.2f} s wall")
    print(f"  largest standard deviation of a line: {worst_std:.3f} dB")
    t_loops = timed(*dev, "measure", "loops", *loops, "--restart-stage", "--out", os.path.join(tmp, "l.csv"))
    t_loops_sim = timed("measure", "loops", "--scenario", scenario, *loops, "--out", os.path.join(tmp, "ls.csv"))
    print("measure loops, 4 amplitudes x 2 cycles at 1 Hz (8 s at 10 kHz):")
    print(f"  emulated board (qemu-m7): {t_loops:6.2f} s wall")
    print(f"  simulator:                {t_loops_sim:6.2f} s wall")
finally:
    if emu.poll() is None:
        emu.send_signal(signal.SIGTERM)
        emu.wait(timeout=10)
