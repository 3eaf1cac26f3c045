#!/usr/bin/python3
"""End-to-end checks of `piezoloop design` on the models in configs/models and
of its error paths.

The sections printed by the command are evaluated here, independently, in
the z^-1 form the core runs, and compared with the exact responses of
tests/golden/design_c2d.json (mpmath) and with analytic filter properties.
Usage: check_design.py PIEZOLOOP_BINARY SOURCE_DIR
"""
import cmath
import json
import math
import os
import subprocess
import sys
import tempfile

exe, src = sys.argv[1], sys.argv[2]
models = os.path.join(src, "configs", "models")
golden = {c["name"]: c for c in json.load(open(os.path.join(src, "tests", "golden", "design_c2d.json")))}
passed = failed = 0


def check(ok, what):
    global passed, failed
    if ok:
        passed += 1
    else:
        failed += 1
        print("FAIL", what)


def run(*args):
    return subprocess.run([exe, "design", *args], capture_output=True, text=True)


def run_json(*args):
    r = run(*args)
    if r.returncode != 0:
        print("FAIL", args, "exit", r.returncode, r.stderr)
        return None
    return json.loads(r.stdout)


def sos_response(sections, f_hz, rate_hz):
    # Each section evaluated in w = z - 1 (as the design does) so that the
    # slow section's 1 + a1 + a2 ~ 1e-9 does not cancel.
    th = 2 * math.pi * f_hz / rate_hz
    w = complex(-2 * math.sin(th / 2) ** 2, math.sin(th))
    h = 1
    for s in sections:
        b0, b1, b2, a1, a2 = s["b0"], s["b1"], s["b2"], s["a1"], s["a2"]
        num = (b0 * w + (2 * b0 + b1)) * w + ((b0 + b1) + b2)
        d1 = a1 + 2.0
        den = (w + d1) * w + (d1 + (a2 - 1.0))
        h *= num / den
    return h


def model(name):
    return os.path.join(models, name)


# --- K(s) at 100 kHz, Q31: fit, and the sections realise the exact Tustin map.
k = run_json("c2d", "--model", model("ahmad2020_K.json"), "--rate-hz", "100000",
             "--in-full-scale", "0.01", "--out-full-scale", "10")
if k:
    check(k["method"] == "tustin" and len(k["sections"]) == 3, "K: tustin, 3 sections")
    check(k["realisation"]["fit"] is True and k["realisation"]["configured"] is True, "K q31 fit")
    check(k["realisation"]["max_error_db"] < 0.01, f"K q31 error {k['realisation']['max_error_db']} dB")
    g = golden["K_100k_tustin"]
    # Sections vs the exact (mpmath) discretisation. The zpk design is exact
    # to ~1e-11, but a section's a2 near 1 is a double with ulp 1.1e-16, so
    # the slow section's 1 + a1 + a2 ~ 1.06e-9 (its DC gain) is only
    # representable to ~1e-7 relative: 1e-6.
    worst = max(abs(sos_response(k["sections"], f, 1e5) - complex(*h)) / abs(complex(*h))
                for f, h in zip(g["freqs_hz"], g["h"]))
    check(worst < 1e-6, f"K sections vs exact response: {worst:.2e}")
    # Internal nodes scaled to full scale (L1), the output's norm reported.
    norms = k["scaling"]["partial_norms"]
    check(all(abs(v - 1.0) < 1e-9 for v in norms[:-1]) and norms[-1] < 1.0, f"K scaling {norms}")

# --- the same in float32: the delta-operator sections hold the slow pole
# pair, --strict exits 0, the form of every section is reported.
r = run("c2d", "--model", model("ahmad2020_K.json"), "--rate-hz", "100000", "--format", "float", "--strict")
kf = json.loads(r.stdout) if r.stdout else None
check(r.returncode == 0 and kf and kf["realisation"]["fit"] is True, f"K float fit, exit {r.returncode}")
if kf:
    forms = kf["realisation"].get("section_forms", [])
    check(len(forms) == len(kf["sections"]) and "delta operator" in forms[-1], f"K float forms {forms}")
    check(kf["realisation"]["max_error_db"] < 0.1 and kf["realisation"]["max_phase_error_deg"] < 1.0,
          f"K float error {kf['realisation']['max_error_db']} dB {kf['realisation']['max_phase_error_deg']} deg")

# --- ZOH and matched of G(s) and D(s): run, and match the exact responses.
for name, file, rate, method, tol in (("G_100k_zoh", "ahmad2020_G.json", 1e5, "zoh", 1e-6),
                                      ("D_5k_zoh", "janaideh2016_D.json", 5e3, "zoh", 1e-6),
                                      ("D_5k_matched", "janaideh2016_D.json", 5e3, "matched", 1e-8),
                                      ("C_5k_tustin", "janaideh2016_C.json", 5e3, "tustin", 1e-8)):
    out = run_json("c2d", "--model", model(file), "--rate-hz", str(rate), "--method", method, "--no-check")
    if out:
        g = golden[name]
        worst = max(abs(sos_response(out["sections"], f, rate) - complex(*h)) / abs(complex(*h))
                    for f, h in zip(g["freqs_hz"], g["h"]))
        check(worst < tol, f"{name}: sections vs exact response {worst:.2e}")

# --- pre-warped Tustin: H_m at 1 kHz.
hm = run_json("c2d", "--model", model("ahmad2020_Hm.json"), "--rate-hz", "100000", "--prewarp-hz", "1000",
              "--no-check")
if hm:
    g = golden["Hm_100k_tustin_prewarp1k"]
    worst = max(abs(sos_response(hm["sections"], f, 1e5) - complex(*h)) / abs(complex(*h))
                for f, h in zip(g["freqs_hz"], g["h"]))
    check(worst < 1e-8 and hm["prewarp_hz"] == 1000.0, f"Hm prewarp {worst:.2e}")

# --- an already discrete model at its own rate: no discretisation.
q = run_json("c2d", "--model", model("shan2012_Q.json"), "--rate-hz", "100000")
if q:
    check(q["method"].startswith("none") and len(q["sections"]) == 1, "Q: already discrete")
    check(abs(abs(sos_response(q["sections"], 1e-3, 1e5)) - 1.0) < 1e-9, "Q: DC gain 1")

# --- standard filters.
n = run_json("notch", "--rate-hz", "100000", "--frequency-hz", "1000", "--depth-db", "-40", "--width-hz", "100")
if n:
    h0 = abs(sos_response(n["sections"], 1000.0, 1e5))
    check(abs(h0 - 0.01) < 1e-8, f"notch depth {h0}")  # pre-warped: exact at f0
    check(abs(abs(sos_response(n["sections"], 1e-3, 1e5)) - 1.0) < 1e-9, "notch DC gain 1")
    check(n["realisation"]["fit"] is True, "notch q31 fit")
lp = run_json("lowpass", "--rate-hz", "100000", "--frequency-hz", "5000", "--zeta", "0.25", "--format", "float")
if lp:
    check(abs(abs(sos_response(lp["sections"], 5000.0, 1e5)) - 2.0) < 1e-9, "lowpass |H(f0)| = Q = 2")
    check(lp["realisation"]["fit"] is True, "lowpass float fit")
ll = run_json("leadlag", "--rate-hz", "10000", "--zero-hz", "100", "--pole-hz", "1000", "--gain", "2")
if ll:
    ph = math.degrees(cmath.phase(sos_response(ll["sections"], math.sqrt(1e5), 1e4)))
    check(abs(ph - math.degrees(math.asin(900 / 1100))) < 1e-7, f"leadlag phase {ph}")

# --- bad input: every case exits non-zero, names the field, prints nothing on stdout.
bad_models = {
    "leading_zero": ({"num": [1], "den": [0, 1, 2]}, "model.den[0]"),
    "improper": ({"num": [1, 2, 3], "den": [1, 1]}, "improper"),
    "empty": ({"num": [], "den": [1, 1]}, "model.num"),
    "not_number": ({"num": [1, "2"], "den": [1, 1]}, "model.num[1]"),
    "conjugate": ({"zeros": [], "poles": [[-1, 2], [-1, 3]], "gain": 1}, "model.poles[0]"),
    "series": ({"series": [{"num": [1], "den": [1, 1]}, {"num": [1], "den": [0, 1]}]}, "model.series[1].den[0]"),
    "mixed_ts": ({"series": [{"num": [1], "den": [1, 0.5], "ts": 1e-5}, {"num": [1], "den": [1, 1]}]},
                 "model.series[1].ts"),
    "ts": ({"num": [1], "den": [1, 1], "ts": -1}, "model.ts"),
    "unknown": ({"numerator": [1], "den": [1, 1]}, "model.numerator"),
    "form": ({"gain": 1}, "model"),
}
with tempfile.TemporaryDirectory() as tmp:
    for name, (content, field) in bad_models.items():
        path = os.path.join(tmp, name + ".json")
        with open(path, "w") as f:
            json.dump(content, f)
        r = run("c2d", "--model", path, "--rate-hz", "100000")
        check(r.returncode != 0 and field in r.stderr and r.stdout == "" and "error" in r.stderr,
              f"bad model {name}: exit {r.returncode}, stderr {r.stderr.strip()!r}")
    path = os.path.join(tmp, "broken.json")
    with open(path, "w") as f:
        f.write('{"num": [1], "den": [1, 1')
    r = run("c2d", "--model", path, "--rate-hz", "100000")
    check(r.returncode == 2 and "not valid JSON" in r.stderr and r.stdout == "", f"broken json: {r.stderr!r}")
    with open(path, "w") as f:
        f.write('{"num": [1], "den": [1, 1e999]}')
    r = run("c2d", "--model", path, "--rate-hz", "100000")
    check(r.returncode == 2 and "model.den[1]: number out of the range of a double" in r.stderr and r.stdout == "",
          f"number beyond a double: {r.stderr!r}")
r = run("c2d", "--model", os.path.join(models, "no_such_model.json"), "--rate-hz", "100000")
check(r.returncode != 0 and "cannot open" in r.stderr, f"missing file: {r.stderr!r}")
for args, field in ((["c2d", "--model", model("ahmad2020_K.json"), "--rate-hz", "0"], "rate_hz"),
                    (["c2d", "--model", model("ahmad2020_K.json"), "--rate-hz", "1e5", "--prewarp-hz", "7e4"],
                     "prewarp_hz"),
                    (["c2d", "--model", model("shan2012_Q.json"), "--rate-hz", "1e4"], "model.ts"),
                    (["notch", "--rate-hz", "1e5", "--frequency-hz", "1e3", "--depth-db", "-1", "--width-hz", "10"],
                     "depth_db"),
                    (["lowpass", "--rate-hz", "1e5", "--frequency-hz", "6e4"], "frequency_hz"),
                    (["leadlag", "--rate-hz", "1e4", "--zero-hz", "10", "--pole-hz", "100", "--gain", "0"], "gain"),
                    (["c2d", "--model", model("ahmad2020_K.json"), "--rate-hz", "1e5", "--method", "foh"], "method")):
    r = run(*args)
    check(r.returncode != 0 and field in r.stderr and r.stdout == "", f"{args}: exit {r.returncode} {r.stderr!r}")

print(f"{passed} passed, {failed} failed")
sys.exit(1 if failed else 0)
