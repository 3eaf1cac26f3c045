#!/usr/bin/python3
"""End-to-end checks of `piezoloop analyze loop|rc|pi`: the Ahmad2020 loop
from the published coefficients against the numpy references in
tests/golden (analysis_loop.json, analysis_robust.json), the RC conditions on
a loop with a known answer, the PI composition, --plot, and the error paths
(exit code 2, "error:" on stderr, nothing on stdout).
Usage: check_analyze.py PIEZOLOOP_BINARY GOLDEN_DIR"""
import json
import math
import os
import subprocess
import sys
import tempfile

exe, golden_dir = sys.argv[1], sys.argv[2]
failures = 0
checks = 0
tmp = tempfile.mkdtemp(prefix="check_analyze_")


def fail(msg):
    global failures
    print("FAIL " + msg)
    failures += 1


def check(cond, msg):
    global checks
    checks += 1
    if not cond:
        fail(msg)


def near(got, want, rel, msg):
    check(got is not None and abs(got - want) <= rel * abs(want), f"{msg}: {got} vs {want}")


def write(name, obj):
    path = os.path.join(tmp, name)
    with open(path, "w") as f:
        json.dump(obj, f)
    return path


def run(*args):
    return subprocess.run([exe, "analyze", *args], capture_output=True, text=True)


def run_json(*args):
    r = run(*args)
    if r.returncode != 0:
        fail(f"{' '.join(args)}: exit {r.returncode}: {r.stderr}")
        return None
    return json.loads(r.stdout)


# Models as users write them (docs/models.md, 'Published controllers', 'Ahmad2020').
G = write("G.json", {"num": [2.01e11, 4.74e15, 2.76e19, 1.84e23],
                     "den": [1, 1.08e4, 2.95e8, 1.98e12, 1.65e16, 5.79e19, 2.05e23]})
K = write("K.json", {"num": [5.29e6, 1.78e10, 1.04e15, 7.66e17, 1.51e22, 4.73e22],
                     "den": [1, 4.69e5, 3.21e10, 7.86e14, 7.38e18, 4.71e19, 7.79e19]})
HE = write("He.json", {"num": [0.5, 1260], "den": [1, 3.78]})
HY = write("Hy.json", {"series": [{"num": [1, 5000], "den": [1e-4, 7500]}, {"num": [1, 5000], "den": [1e-4, 7500]}]})
HM = write("Hm.json", {"series": [{"num": [0.02], "den": [1]},
                                  {"num": [1, 44100, 3.969e7], "den": [1, 630, 3.969e7]},
                                  {"num": [1, 19600, 1.96e8], "den": [1, 2240, 1.96e8]},
                                  {"num": [1e-8, 1e4], "den": [1, 1e4]}]})

# ---- analyze loop: Ahmad2020, continuous. Tolerances as in the unit tests
# (H-infinity 1e-6, margins 1e-6 dB/deg, family counts exact).
ref = next(c for c in json.load(open(f"{golden_dir}/analysis_loop.json"))["cases"] if c["name"] == "ahmad2020")
fam = json.load(open(f"{golden_dir}/analysis_robust.json"))
png = os.path.join(tmp, "loop.png")
out = run_json("loop", "--plant", G, "--controller", K, "--we", HE, "--wy", HY, "--hm", HM, "--phase-lag-hz", "10",
               "--plot", png)
if out:
    check(out["stable"] is True, "ahmad2020 loop stable")
    near(out["poles_max_real"], ref["stability_measure"], 1e-6, "poles_max_real")
    for key in ("hinf_S", "hinf_T", "hinf_KS", "hinf_GS", "hinf_WeS", "hinf_WyT", "hinf_HmT"):
        near(out[key], ref[key], 1e-6, key)
    near(out["gain_margin_db"], ref["phase_crossovers"][0]["gm_db"], 1e-7, "gain_margin_db")
    near(out["phase_margin_deg"], ref["gain_crossovers"][0]["pm_deg"], 1e-7, "phase_margin_deg")
    near(out["bandwidth_hz"], ref["bandwidth_w"] / (2 * math.pi), 1e-7, "bandwidth_hz")
    check(out["nominal_performance"] is True, "nominal performance (both weighted norms < 1)")
    rs = out["robust_stability"]
    check(rs["robustly_stable"] is True, "||H_m T|| < 1")
    check(rs["family"]["count"] == 729, "family count")
    check(rs["family"]["unstable"] == fam["unstable"], f"family unstable {rs['family']['unstable']} vs {fam['unstable']}")
    near(rs["family"]["worst_stability"]["poles_max"], fam["worst_stability_measure"], 1e-6, "family worst pole")
    check(len(out["phase_lag"]) == 1 and out["phase_lag"][0]["phase_lag_deg"] > 0, "phase lag reported")
    check(os.path.getsize(png) > 1000 and open(png, "rb").read(4) == b"\x89PNG", "--plot wrote a PNG")

# Discretised at 10 kHz (the source's rate): still stable, |z| < 1.
out = run_json("loop", "--plant", G, "--controller", K, "--rate-hz", "10000")
if out:
    check(out["stable"] is True and 0.99 < out["poles_max_abs"] < 1.0, f"ahmad2020 at 10 kHz: {out.get('poles_max_abs')}")
    check(out["ts"] == 1e-4, "ts of the discretised loop")

# ---- analyze rc: T = z^-1, Q = 1, m1 = 0, m2 = 1 (see test_rc_analysis.cpp):
# k_rc_max = 2 exactly, |root| = |1 - k_rc|^(1/N).
T = write("T.json", {"zeros": [], "poles": [0], "gain": 1, "ts": 1e-5})
Q1 = write("Q1.json", {"num": [1], "den": [1], "ts": 1e-5})
for k, ok in ((0.8, True), (2.5, False)):
    out = run_json("rc", "--closed-loop", T, "--q", Q1, "--krc", str(k), "--m1", "0", "--m2", "1",
                   "--period-samples", "10")
    if out:
        near(out["condition_2_gain"]["k_rc_max"], 2.0, 1e-9, "rc k_rc_max")
        check(out["ok"] is ok and (len(out["failures"]) == 0) == ok, f"rc verdict for k_rc {k}")
        near(out["exact"]["max_abs_root"], abs(1 - k) ** 0.1, 1e-9, "rc exact root")
# Shan2012 Q on the delay with the published PI hysteresis: (21) is evaluated.
QS = write("Q.json", {"zeros": [], "poles": [0.6442], "gain": 0.3558, "ts": 1e-5})
out = run_json("rc", "--closed-loop", T, "--q", QS, "--krc", "0.8", "--m1", "6", "--m2", "0", "--period-samples", "100",
               "--pi-shan2012")
if out:
    a = 0.6442  # |Q| = |Q(1)|/sqrt(2): cos wc = (1 + a^2 - 2 (1 - a)^2) / (2 a)
    fc = math.acos((1 + a * a - 2 * (1 - a) ** 2) / (2 * a)) / (2 * math.pi * 1e-5)
    near(out["q_cutoff_hz"], fc, 1e-7, "Shan2012 Q cutoff")
    near(out["phase_90_at_hz"], 25000.0, 1e-7, "90 deg at fs/4 for a unit delay")
    check("condition_21" in out["hysteresis"], "condition 21 reported")

# ---- analyze pi: Janaideh2016 numerical example against a 5 % low estimate.
P = write("P.json", {"thresholds": [0, 4, 8, 12, 16, 20, 24, 28, 32, 36, 40],
                     "weights": [0.1, 0.0461, 0.069, 0.1029, 0.1535, 0.2291, 0.3417, 0.5098, 0.7605, 1.1345, 1.6925]})
PE = write("PE.json", {"thresholds": [0, 4, 8, 12, 16, 20, 24, 28, 32, 36, 40],
                       "weights": [0.1] + [0.95 * w for w in [0.0461, 0.069, 0.1029, 0.1535, 0.2291, 0.3417, 0.5098,
                                                              0.7605, 1.1345, 1.6925]]})
out = run_json("pi", "--model", P, "--estimate", PE)
if out:
    check(out["monotone"] is True and out["xi_bound"] > 0 and out["rho"] > 1.0, f"pi composition: {out.get('rho')}")
out = run_json("pi", "--model", P, "--estimate", P)
if out:
    near(out["rho"], 1.0, 1e-5, "exact inverse: rho = 1")

# ---- errors: exit 2, "error:" naming the field, nothing on stdout.
BAD = write("bad.json", {"num": [1], "den": [0, 1]})
CT = write("Tc.json", {"num": [1], "den": [1, 1]})
for args, needle in (
    (["loop", "--plant", os.path.join(tmp, "missing.json"), "--controller", K], "missing.json"),
    (["loop", "--plant", BAD, "--controller", K], "den[0]"),
    (["loop", "--plant", G, "--controller", T], "controller"),
    (["rc", "--closed-loop", T, "--q", Q1, "--krc", "0.8", "--m1", "6", "--m2", "5", "--period-samples", "10"], "m1 - m2"),
    (["rc", "--closed-loop", CT, "--q", Q1, "--krc", "0.8", "--m1", "0", "--m2", "0", "--period-samples", "10"], "ts"),
    (["rc", "--q", Q1, "--krc", "0.8", "--m1", "0", "--m2", "0", "--period-samples", "10"], "closed-loop"),
    (["pi", "--model", P], "estimate"),
    (["loop", "--plant", G, "--controller", K, "--phase-lag-hz", "10,x"], "phase-lag-hz"),
):
    r = run(*args)
    check(r.returncode == 2 and "error:" in r.stderr and needle in r.stderr and r.stdout == "",
          f"{args}: exit {r.returncode}, stderr {r.stderr!r}, stdout {r.stdout[:80]!r}")

print(f"{checks - failures} passed, {failures} failed")
sys.exit(1 if failures else 0)
