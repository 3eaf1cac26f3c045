#!/usr/bin/python3
"""`piezoloop sim` on a stage of coupled axes (configs/stages/xyz_flexure.json).

 - the JSON's cross motion equals the peak-to-peak of the held axes' true
   positions in the --out CSV over the last period, as % of the driven
   axis's reference range (the CSV's 9 significant digits give the float
   samples back exactly, so the figures agree exactly);
 - a bad case (unknown axis, a matrix not n x n, a singular one) exits 2
   naming the field;
 - --hash prints the JSON's log_hash, and a second run gives it again
   (float and Q31 runs are compared in tests/host/sim/test_multi_axis_loop.cpp).
Usage: check_sim_axes.py PIEZOLOOP CONFIGS_DIR"""
import csv
import json
import os
import struct
import subprocess
import sys
import tempfile

exe, configs = sys.argv[1:3]
passed = failed = 0


def check(name, ok, detail=""):
    global passed, failed
    if ok:
        passed += 1
    else:
        failed += 1
        print(f"FAIL {name}: {detail}")


def run(args):
    return subprocess.run([exe] + args, capture_output=True, text=True)


def f32(text):
    return struct.unpack("f", struct.pack("f", float(text)))[0]


tmp = tempfile.mkdtemp(prefix="check_sim_axes_")
xyz = os.path.join(configs, "stages", "xyz_flexure.json")
# open_loop: no controller whose realisation check (the notes) takes seconds.
base = ["sim", "--scenario", xyz, "--case", "open_loop", "--axis", "x", "--frequency-hz", "10",
        "--amplitude-um", "80", "--midpoint-um", "50", "--hold-um", "y=50", "--hold-um", "z=7.5"]
out = os.path.join(tmp, "xyz.csv")
r = run(base + ["--out", out])
check("sim on xyz runs", r.returncode == 0, r.stderr)
if r.returncode == 0:
    j = json.loads(r.stdout)
    check("driven axis named", j["axis"] == "x", j.get("axis"))
    check("held axes listed", set(j["cross_motion_pct"]) == {"y", "z"}, j["cross_motion_pct"])
    rows = list(csv.DictReader(open(out)))
    start = j["window_start_tick"]
    window = [row for row in rows if int(row["tick"]) >= start]
    check("CSV covers the window", len(window) == j["window_ticks"], f"{len(window)} vs {j['window_ticks']}")
    r_x = [f32(row["r_x_um"]) for row in window]
    span = max(r_x) - min(r_x)
    for axis in ("y", "z"):
        p = [f32(row[f"p_{axis}_um"]) for row in window]
        pct = 100.0 * (max(p) - min(p)) / span
        check(f"cross motion of {axis} from the CSV", pct == j["cross_motion_pct"][axis],
              f"{pct!r} vs {j['cross_motion_pct'][axis]!r}")
    h = run(base + ["--hash"])
    check("--hash is the JSON's log_hash", h.returncode == 0 and h.stdout.strip() == j["log_hash"],
          f"{h.stdout.strip()} vs {j['log_hash']}")
    closed = [a if a != "open_loop" else "pi_notch_decoupled" for a in base] + ["--hash"]
    h1, h2 = run(closed), run(closed)
    check("--hash repeats (closed loop)", h1.returncode == 0 and h2.stdout == h1.stdout and h1.stdout != h.stdout,
          f"{h1.stdout} {h2.stdout} {h1.stderr}")

# A bad case of several axes: exit 2, the field named, nothing run.
spec = json.load(open(xyz))
for why, edit, needle in [
        ("unknown axis name", lambda c: c["axes"].__setitem__("w", c["axes"]["x"]),
         "cases[1].controller.axes.w: no axis of that name (axes: x, y, z)"),
        ("output_matrix not 3 x 3", lambda c: c.__setitem__("output_matrix", [[1, 0], [0, 1]]),
         "cases[1].controller.output_matrix: must be 3 rows"),
        ("singular output_matrix", lambda c: c.__setitem__("output_matrix", [[1, 1, 0], [1, 1, 0], [0, 0, 1]]),
         "cases[1].controller.output_matrix: singular")]:
    bad = json.loads(json.dumps(spec))
    edit(bad["cases"][1]["controller"])
    path = os.path.join(tmp, "bad.json")
    json.dump(bad, open(path, "w"))
    r = run(["sim", "--scenario", path, "--case", "open_loop", "--axis", "x", "--amplitude-um", "5"])
    check(f"refused: {why}", r.returncode == 2 and needle in r.stderr and r.stdout == "",
          f"exit {r.returncode}, stderr {r.stderr[-300:]!r}")

print(f"{passed} passed, {failed} failed")
sys.exit(1 if failed else 0)
