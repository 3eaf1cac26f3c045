#!/usr/bin/python3
"""A wave started after another was stopped mid-way, with a reference
pre-filter, on an emulated board (qemu-m7 float or qemu-m3 Q31): the
Ahmad2020 stage and its dahl_ff_K controller at 10 kHz, plus a 300 Hz
low-pass pre-filter (zeta 0.7, Tustin at the loop rate, DC gain 1).

  record --start-wave --restart-stage   a slow triangle, then `stop` mid-way
  disarm                                the stage comes to rest near 0 um while
                                        the pre-filter runs on the held setpoint
  record                                (disarmed) the held r and the reading
  record --start-wave                   the next triangle: approach from the reading

The second wave's filtered r must start where the stage is and move no
faster than the approach allows:
- its first value within 0.02 um of the first reading (the stage at rest
  reads within its noise of where it was the tick before; the setpoint the
  pre-filter held is checked to be over 3 um away);
- no step of r beyond v_max / rate (v_max = 10 position full scales per
  second, approach.hpp), 5 % over it for the low-pass's overshoot on a smooth
  move. A step through the pre-filter from a setpoint held ~6 um away is
  over ten times the bound (0.55 um against 0.04 um).

Usage: check_prefilter_start_e2e.py PIEZOLOOP SERVO_ELF CONFIGS_DIR qemu-m7|qemu-m3
Exit 77 (skipped) without qemu-system-arm or the image."""
import csv
import json
import math
import os
import shutil
import subprocess
import sys
import tempfile

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
from board_checks import Checks, Emulators, skip_without_qemu  # noqa: E402

exe, image, configs, board = sys.argv[1], sys.argv[2], sys.argv[3], sys.argv[4]
skip_without_qemu(image)
scenario = os.path.join(configs, "ahmad2020.json")
rate = 10000
check = Checks()
emus = Emulators(exe)
tmp = tempfile.mkdtemp(prefix="check_prefilter_start_e2e_")


def run(*args):
    return subprocess.run([exe, *args], capture_output=True, text=True, timeout=300)


def rows(path):
    with open(path) as f:
        return list(csv.DictReader(f))


def lowpass_section(f_Hz, zeta, fs):
    """w^2 / (s^2 + 2 zeta w s + w^2) by Tustin (s = 2 fs (z - 1) / (z + 1)), a0 = 1."""
    w, k = 2 * math.pi * f_Hz, 2 * fs
    a0 = k * k + 2 * zeta * w * k + w * w
    return {"b0": w * w / a0, "b1": 2 * w * w / a0, "b2": w * w / a0,
            "a1": (2 * w * w - 2 * k * k) / a0, "a2": (k * k - 2 * zeta * w * k + w * w) / a0}


try:
    emu, d, info = emus.start("--board", board, "--scenario", scenario, "--image", image)
    check(info["board"] == board and info["loop_rate_Hz"] == rate, f"emulate: {board} up at {rate} Hz", str(info))
    full_scale = json.loads(run(*d, "status").stdout)["hello"]["position_full_scale_um"]
    r = run(*d, "set", "--scenario", scenario, "--case", "dahl_ff_K")
    check(r.returncode == 0, "set --scenario ahmad2020 dahl_ff_K", r.stderr)
    pf = json.dumps({"prefilter": [lowpass_section(300.0, 0.7, rate)]})
    r = run(*d, "set", "feedforward", "--json", pf)
    check(r.returncode == 0 and len(json.loads(r.stdout)["set"]["feedforward"]["prefilter"]) == 1,
          "set feedforward: a 300 Hz low-pass pre-filter", r.stderr)

    # The first wave: a slow 12 um triangle, stopped mid-way (on its rise).
    slow = ["--trajectory", "triangle", "--frequency-hz", "0.5", "--amplitude-um", "12", "--scenario", scenario]
    r = run(*d, "record", "--signals", "r,y", "--duration-s", "0.6", *slow, "--start-wave", "--restart-stage",
            "--out", os.path.join(tmp, "first.csv"))
    s = run(*d, "stop")
    check(r.returncode == 0 and s.returncode == 0, "the first wave recorded and stopped mid-way", r.stderr + s.stderr)
    r = run(*d, "disarm")
    check(r.returncode == 0, "disarmed", r.stderr)
    # The stage comes to rest; the pre-filter runs on the held setpoint.
    r = run(*d, "record", "--signals", "r,y", "--duration-s", "0.3", "--out", os.path.join(tmp, "rest.csv"))
    rest = rows(os.path.join(tmp, "rest.csv")) if r.returncode == 0 else []
    held, resting = (float(rest[-1]["r_um"]), float(rest[-1]["y_um"])) if rest else (0.0, 0.0)
    check(r.returncode == 0 and abs(held - resting) > 3.0,
          f"disarmed: r holds the stopped wave's {held:.3f} um, the stage rests at {resting:.3f} um", r.stderr)

    # The next wave, arming the loop at its first tick: approach from the reading.
    wave = ["--trajectory", "triangle", "--frequency-hz", "10", "--amplitude-um", "12", "--scenario", scenario]
    out = os.path.join(tmp, "second.csv")
    r = run(*d, "record", "--signals", "r,y", "--duration-s", "0.05", *wave, "--start-wave", "--out", out)
    rj = json.loads(r.stdout) if r.stdout.strip() else {}
    check(r.returncode == 0 and rj.get("lost_blocks") == 0, "the second wave recorded, nothing lost", r.stderr)
    rec = rows(out) if r.returncode == 0 else []
    r_um = [float(x["r_um"]) for x in rec]
    y_um = [float(x["y_um"]) for x in rec]
    na = rj.get("approach_ticks", 0)
    check(na > 0, f"the second wave approaches its first point ({na} ticks)", str(na))
    if r_um:
        check(abs(r_um[0] - y_um[0]) <= 0.02,
              f"the filtered r starts where the stage is: r {r_um[0]:.4f} um, y {y_um[0]:.4f} um",
              f"held setpoint {held:.4f} um")
        bound = 10.0 * full_scale / rate
        steps = [abs(b - a) for a, b in zip(r_um, r_um[1:na + 50])]
        check(max(steps) <= 1.05 * bound,
              f"no jump through the pre-filter: largest step {max(steps):.4e} um, v_max / rate {bound:.4e} um",
              str(max(steps)))
finally:
    emus.stop_all()
    shutil.rmtree(tmp, ignore_errors=True)
check.exit()
