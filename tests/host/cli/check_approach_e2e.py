#!/usr/bin/python3
"""A wave that starts away from the stage, on qemu-m7 against the simulator:
Janaideh2016's bipolar stage and ff_fb controller at 100 kHz, a 20 um
peak-to-peak 10 Hz triangle centred on 0, whose first point is -10 um while
the stage rests at 0.

  piezoloop --device ... record --start-wave --restart-stage  (0.1 s)

must equal `piezoloop sim` bit for bit (r, y, e, u, the log hash), and its
r must be the approach (common/piezoloop/approach.hpp), then the wave:
- approach_ticks > 0 (the ticks before the wave's first point; the record
  and the simulator both put them in front of the 0.1 s of the wave);
- no jump: no step of r beyond v_max / rate, v_max = 10 position full scales
  per second (hello's position_full_scale_um), and the peak step within 10 %
  of it (N is the shortest move within the bound);
- continuous first derivative: the move leaves and reaches -10 um at rest
  (first and last steps below 11 |D| / N^3 + 1e-6 um);
- then the triangle unchanged: from the approach's end r is
  offset + A * tri(f * (k - approach_ticks) / rate), computed here, within 1e-5 um
  (float rounding of r ~ 10 um, the generator's shape within 2 Q31 LSB).

Usage: check_approach_e2e.py PIEZOLOOP SERVO_ELF CONFIGS_DIR
Exit 77 (skipped) without qemu-system-arm or the image."""
import csv
import json
import os
import shutil
import subprocess
import sys
import tempfile

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
from board_checks import Checks, Emulators, skip_without_qemu  # noqa: E402

exe, image, configs = sys.argv[1], sys.argv[2], sys.argv[3]
skip_without_qemu(image)
scenario = os.path.join(configs, "janaideh2016.json")
rate, seconds, f_Hz, range_um = 100000, 0.1, 10.0, 20.0
frames = int(round(rate * seconds))
check = Checks()
emus = Emulators(exe)
tmp = tempfile.mkdtemp(prefix="check_approach_e2e_")


def run(*args):
    return subprocess.run([exe, *args], capture_output=True, text=True, timeout=300)


def rows(path):
    with open(path) as f:
        return list(csv.DictReader(f))


try:
    emu, d, info = emus.start("--board", "qemu-m7", "--scenario", scenario, "--image", image)
    check(info["board"] == "qemu-m7" and info["loop_rate_Hz"] == rate, "emulate: qemu-m7 up at 100 kHz", str(info))
    hello = json.loads(run(*d, "status").stdout)["hello"]
    full_scale = hello["position_full_scale_um"]
    r = run(*d, "set", "--scenario", scenario, "--case", "ff_fb", "--frequency-hz", "10")
    check(r.returncode == 0, "set --scenario janaideh2016 ff_fb", r.stderr)

    wave = ["--trajectory", "triangle", "--frequency-hz", str(f_Hz), "--amplitude-um", str(range_um),
            "--offset", "bipolar"]
    rec_csv, sim_csv = os.path.join(tmp, "rec.csv"), os.path.join(tmp, "sim.csv")
    r = run(*d, "record", "--signals", "r,y,e,u", "--duration-s", str(seconds), *wave, "--scenario", scenario,
            "--start-wave", "--restart-stage", "--out", rec_csv)
    rj = json.loads(r.stdout) if r.stdout.strip() else {}
    na = rj.get("approach_ticks", 0)  # ticks before the wave's first point: N - 1
    check(r.returncode == 0 and rj.get("frames") == frames + na and rj.get("lost_blocks") == 0,
          f"record: the approach ({na} ticks) and {frames} frames of the wave, nothing lost", r.stderr)
    frames += na
    s = run("sim", "--scenario", scenario, "--case", "ff_fb", *wave, "--duration-s", str(seconds), "--out", sim_csv)
    sj = json.loads(s.stdout) if s.returncode == 0 else {}
    check(s.returncode == 0, "piezoloop sim ran", s.stderr)
    rec, ref = rows(rec_csv), rows(sim_csv)
    columns = ("t_s", "r_um", "y_um", "e_um", "u_V")
    diff = [i for i, (a, b) in enumerate(zip(rec, ref)) if any(a[c] != b[c] for c in columns)]
    check(len(rec) == len(ref) == frames and not diff, "record r, y, e, u equal `piezoloop sim` bit for bit",
          f"{len(rec)} vs {len(ref)} rows, first difference at row {diff[0] if diff else None}")
    check(rj.get("log_hash") == sj.get("log_hash"), "record log_hash equals the simulator's",
          f"{rj.get('log_hash')} vs {sj.get('log_hash')}")

    check(sj.get("approach_ticks") == na, "the simulator approaches for as many ticks",
          f"{sj.get('approach_ticks')} vs {na}")
    big_n = na + 1
    r_um = [float(x["r_um"]) for x in rec]
    first = -0.5 * range_um
    bound = 10.0 * full_scale / rate  # v_max per tick
    check(na > 0 and na < frames, f"the wave approaches its first point ({na} ticks)", str(na))
    if 0 < na < frames:
        move = [0.0] + r_um[:na + 1]  # the stage at rest, the approach, the wave's first point
        steps = [abs(b - a) for a, b in zip(move, move[1:])]
        peak = 15.0 / 8.0 * abs(first) / big_n
        check(max(steps) <= bound * (1 + 1e-6) and max(steps) > 0.9 * peak,
              f"no jump: largest step {max(steps):.3e} um within v_max / rate = {bound:.3e} um",
              f"{max(steps)} vs {bound}, peak {peak}")
        end_step = 11.0 * abs(first) / big_n ** 3 + 1e-6
        check(steps[0] <= end_step and steps[-1] <= end_step,
              "the move leaves and reaches its ends at rest (continuous first derivative)",
              f"first {steps[0]}, last {steps[-1]}, bound {end_step}")
        check(r_um[na] == first, "the wave's first point is reached exactly", str(r_um[na]))

        def triangle(k):
            x = (f_Hz * k / rate) % 1.0
            return -0.5 * range_um * (1 - 4 * x if x < 0.5 else 4 * x - 3)

        worst = max(abs(r_um[k] - triangle(k - na)) for k in range(na, frames))
        check(worst <= 1e-5, f"then the triangle unchanged (worst {worst:.2e} um)", str(worst))
finally:
    emus.stop_all()
    shutil.rmtree(tmp, ignore_errors=True)
check.exit()
