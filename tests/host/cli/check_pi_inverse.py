#!/usr/bin/python3
"""End-to-end check of `piezoloop pi-inverse` against tests/golden/pi_ref.json
(the numpy loading-curve inverse), and of its error path.
Usage: check_pi_inverse.py PIEZOLOOP_BINARY GOLDEN_DIR"""
import json
import subprocess
import sys

exe, golden_dir = sys.argv[1], sys.argv[2]
golden = json.load(open(f"{golden_dir}/pi_ref.json"))
failures = 0


def run(args):
    return subprocess.run([exe, "pi-inverse", *args], capture_output=True, text=True)


def csv(values):
    return ",".join(repr(v) for v in values)


# Numerical example: threshold 0 carries p0 (no --p0 given).
ex = golden["numerical_example"]
cases = [
    ("numerical_example", [0.0] + ex["thresholds"], [ex["p0"]] + ex["weights"], ex["inverse"]),
    # 15-operator set as published: first threshold 0.095 > 0, no --p0.
    ("set15", [0.095, 0.38, 0.84, 1.46, 2.21, 3.07, 4.01, 4.98, 5.96, 6.89, 7.76, 8.52, 9.14, 9.61, 9.9],
     [2.55, 0.57, 1.3, -1.57, 1.25, -0.054, -0.032, 0.66, 0.16, -0.77, 2.02, -1.63, -0.15, 2.99, -1.09],
     golden["set15"]["inverse"]),
]
for name, r, p, inv in cases:
    res = run(["--thresholds", csv(r), "--weights", csv(p)])
    if res.returncode != 0:
        print(f"FAIL {name}: exit {res.returncode}: {res.stderr}")
        failures += 1
        continue
    out = json.loads(res.stdout)
    want_r = [0.0] + inv["thresholds"]
    want_w = [inv["p0"]] + inv["weights"]
    # Printed with 7 significant digits from float: 1e-6 relative.
    for got, want, what in ((out["thresholds"], want_r, "thresholds"), (out["weights"], want_w, "weights")):
        if len(got) != len(want) or any(abs(a - b) > 1e-6 * abs(b) + 1e-9 for a, b in zip(got, want)):
            print(f"FAIL {name} {what}: {got} != {want}")
            failures += 1

bad = run(["--thresholds", "1,2", "--weights", "1,-3", "--p0", "1"])
if bad.returncode == 0 or "weights[1]" not in bad.stderr or bad.stdout:
    print(f"FAIL non-invertible: exit {bad.returncode}, stderr {bad.stderr!r}, stdout {bad.stdout!r}")
    failures += 1
mismatch = run(["--thresholds", "1,2", "--weights", "1"])
if mismatch.returncode == 0 or "weights" not in mismatch.stderr:
    print(f"FAIL length mismatch: {mismatch.stderr!r}")
    failures += 1

checks = 2 * len(cases) + 2
print(f"{checks - failures} passed, {failures} failed")
sys.exit(1 if failures else 0)
