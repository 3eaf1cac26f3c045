#!/usr/bin/python3
"""End to end: `piezoloop analyze measured-loop` on a measure-frf-format file
holding the lines of 1/(s+1)^3 (s in rad/s) with a controller file K = 2 and
--error-per-um 2, so L = 4/(s+1)^3: PM = 180 - 3 atan(w_c) at w_c =
sqrt(4^(2/3) - 1), GM = 20 log10(8/4) dB at w = sqrt(3) (analytic; the
lines are 200 per decade, hence the tolerances of
tests/host/analysis/test_measured_loop.cpp). Then bad input: exit 2 naming
the field.
Usage: check_analyze_measured.py PIEZOLOOP_BINARY
"""
import json
import math
import os
import subprocess
import sys
import tempfile

exe = sys.argv[1]
tmp = tempfile.mkdtemp()
passed = failed = 0


def check(ok, what):
    global passed, failed
    if ok:
        passed += 1
    else:
        failed += 1
        print("FAIL", what)


def write(name, obj):
    path = os.path.join(tmp, name)
    with open(path, "w") as f:
        json.dump(obj, f)
    return path


f_hz = [0.001 * 10 ** (i / 200) for i in range(0, 801)]
resp = []
for f in f_hz:
    g = 1 / (complex(1, 2 * math.pi * f) ** 3)
    resp.append([g.real, g.imag])
frf = write("frf.json", {"frequency_Hz": f_hz, "response": resp, "excitation": {"rate_Hz": 10000}})
k = write("k.json", {"zeros": [], "poles": [], "gain": 2.0})


def run(*args):
    return subprocess.run([exe, "analyze", "measured-loop", *args], capture_output=True, text=True)


r = run("--frf", frf, "--controller", k, "--error-per-um", "2")
check(r.returncode == 0, "run: %d %s" % (r.returncode, r.stderr))
if r.returncode == 0:
    out = json.loads(r.stdout)
    wc = math.sqrt(4 ** (2 / 3) - 1)
    pm = 180 - 3 * math.degrees(math.atan(wc))
    check(abs(out["phase_margin"]["phase_margin_deg"] - pm) < 0.01, "PM %r vs %r" % (out["phase_margin"], pm))
    check(abs(out["phase_margin"]["f_Hz"] - wc / (2 * math.pi)) < 1e-3 * wc / (2 * math.pi), "crossover frequency")
    check(abs(out["gain_margin"]["gain_margin_db"] - 20 * math.log10(2)) < 0.005, "GM %r" % out["gain_margin"])
    check(out["lines"] == len(f_hz) and out["warnings"] == [], "lines and no warning")

no_rate = write("no_rate.json", {"frequency_Hz": f_hz, "response": resp})
r = run("--frf", no_rate, "--controller", k)
check(r.returncode == 2 and "excitation.rate_Hz" in r.stderr, "no rate: %d %s" % (r.returncode, r.stderr))
r = run("--frf", frf, "--controller", k, "--error-per-um", "0")
check(r.returncode == 2 and "--error-per-um" in r.stderr, "error-per-um 0: %d %s" % (r.returncode, r.stderr))
slow = write("slow.json", {"zeros": [], "poles": [], "gain": 1.0, "ts": 0.01})
r = run("--frf", frf, "--controller", slow)
check(r.returncode == 2 and "controller" in r.stderr, "controller at another rate: %d %s" % (r.returncode, r.stderr))

print("%d passed, %d failed" % (passed, failed))
sys.exit(1 if failed else 0)
