#!/usr/bin/python3
"""End-to-end checks of `piezoloop identify rls|pi|dahl` and `piezoloop reduce`
against the golden data of tools/ref/ident_*.py and data simulated here, and
of their error paths (message on stderr naming the field, non-zero exit,
nothing on stdout).
Usage: check_identify.py PIEZOLOOP_BINARY GOLDEN_DIR"""
import json
import math
import os
import subprocess
import sys
import tempfile

import numpy as np

exe, golden_dir = sys.argv[1], sys.argv[2]
tmp = tempfile.mkdtemp(prefix="piezoloop_identify_")
passed = 0
failed = 0


def check(name, ok, detail=""):
    global passed, failed
    if ok:
        passed += 1
    else:
        failed += 1
        print(f"FAIL {name}: {detail}")


def run(*args):
    return subprocess.run([exe, *args], capture_output=True, text=True)


def ok_json(name, res):
    if res.returncode != 0:
        check(name, False, f"exit {res.returncode}: {res.stderr}")
        return None
    try:
        return json.loads(res.stdout)
    except ValueError as e:
        check(name, False, f"stdout is not JSON ({e}): {res.stdout[:200]}")
        return None


def expect_error(name, res, *needles):
    ok = res.returncode != 0 and not res.stdout and all(n in res.stderr for n in needles)
    ok = ok and res.returncode < 128  # a signal (crash) is not an error exit
    check(name, ok, f"exit {res.returncode}, stderr {res.stderr!r}, stdout {res.stdout[:200]!r}")


def write_csv(name, header, columns, fmt=repr):
    path = os.path.join(tmp, name)
    with open(path, "w") as f:
        f.write(",".join(header) + "\n")
        for row in zip(*columns):
            f.write(",".join(fmt(float(v)) for v in row) + "\n")
    return path


def close(a, b, tol):
    return len(a) == len(b) and all(abs(x - y) <= tol for x, y in zip(a, b))


# ------------------------------------------------------------------ rls
g = json.load(open(f"{golden_dir}/ident_rls.json"))
arx_csv = write_csv("arx.csv", ["t", "u", "y"], [g["t"], g["u"], g["y"]])
out = ok_json("rls arx", run("identify", "rls", "--data", arx_csv))
if out:
    # RLS with its 1e-6 prior vs numpy's batch least squares: 1e-6 (see test_rls.cpp).
    check("rls arx a", close(out["a"], g["lstsq"]["a"], 1e-6), f"{out['a']} vs {g['lstsq']['a']}")
    check("rls arx b", close(out["b"], g["lstsq"]["b"], 1e-6), f"{out['b']} vs {g['lstsq']['b']}")
    m = out["model"]
    # ts from the time column: mean step of values printed by repr, 1e-12 relative.
    check("rls model", m.get("ts") is not None and abs(m["ts"] - g["ts"]) < 1e-12 * g["ts"]
          and len(m["den"]) == 3 and m["den"][0] == 1.0 and close(m["num"], out["b"], 0.0),
          json.dumps(m))
    check("rls fit", out["method"] == "rls-arx" and out["stable"] and out["fit"]["fit_percent"] > 80
          and abs(out["fit"]["prediction_rms"] - 0.1) < 0.01, json.dumps(out["fit"]))

# Other column names, explicit period, output-error structure.
named_csv = write_csv("named.csv", ["v_V", "x_um"], [g["u"], g["y"]])
out = ok_json("rls oe", run("identify", "rls", "--data", named_csv, "--input", "v_V", "--output", "x_um",
                            "--ts", "1e-4", "--structure", "oe"))
if out:
    check("rls oe", out["method"] == "steiglitz-mcbride-oe" and out["converged"]
          and abs(out["model"]["ts"] - 1e-4) < 1e-18 and len(out["a"]) == 2, json.dumps(out)[:300])

# ------------------------------------------------------------------ pi
p = json.load(open(f"{golden_dir}/ident_pi.json"))
set15_csv = write_csv("set15.csv", ["u", "y"], [p["u"], p["set15"]["y"]])
thr = ",".join(repr(r) for r in p["set15"]["thresholds"])
# The golden references fit y = PI[u] from rest over every sample: --no-offset --first-fitted 0.
plain = ("--no-offset", "--first-fitted", "0")
out = ok_json("pi set15", run("identify", "pi", "--data", set15_csv, "--thresholds", thr, *plain))
if out:
    # Same least-squares problem as numpy's lstsq: 1e-9 (see test_pi_fit.cpp).
    check("pi set15 weights", close(out["weights"], p["set15"]["lstsq"], 1e-9), str(out["weights"]))
    check("pi set15 thresholds", out["thresholds"] == [0.0] + p["set15"]["thresholds"], str(out["thresholds"]))
    check("pi set15 invertible", out["invertible"] is True and out["grid"] == "explicit", str(out["invertible"]))
nm = p["nonmonotone"]
nm_csv = write_csv("nonmono.csv", ["u", "y"], [p["u"], nm["y"]])
res = run("identify", "pi", "--data", nm_csv, "--operators", "8", *plain)
out = ok_json("pi free", res)
if out:
    # Not invertible is a result (exit 0), said on stderr with what to do.
    check("pi free says why not invertible", "not invertible" in res.stderr and "monotone" in res.stderr
          and "falls while the input rises" in out["invertibility"], res.stderr)
    check("pi free weights", close(out["weights"], nm["lstsq"], 1e-9), str(out["weights"]))
    check("pi free not invertible", out["invertible"] is False and "weights[2]" in out["invertibility"],
          out["invertibility"])
out = ok_json("pi monotone", run("identify", "pi", "--data", nm_csv, "--operators", "8", "--monotone",
                                 "--min-slope", repr(nm["min_slope"]), *plain))
if out:
    # scipy.optimize.nnls on the slope parametrisation: 1e-8 (see test_pi_fit.cpp).
    check("pi monotone weights", close(out["weights"], nm["monotone"], 1e-8), str(out["weights"]))
    check("pi monotone invertible", out["invertible"] is True and out["active_constraints"] == 1, json.dumps(out)[:300])

# Offset and unknown initial play states: a known PI model read with an
# offset of -118 from a periodic wave that starts at mid-range.
kk = np.arange(6 * 200 + 50)
wave = 1.8 - 1.8 * np.cos(2 * np.pi * (kk + 50) / 200)
r_true, p_true, c_true = [0.3, 0.6, 0.9, 1.2, 1.5], [2.0, 3.0, 2.0, 1.5, 1.0, 0.5], -118.0
w = np.array([0.7, -1.0, 2.5, 0.0, 3.0])
yo = []
for x in wave:
    w = np.maximum(x - np.array(r_true), np.minimum(x + np.array(r_true), w))
    yo.append(c_true + p_true[0] * x + float(np.dot(p_true[1:], w)))
off_csv = write_csv("offset.csv", ["u", "y"], [wave, yo])
res = run("identify", "pi", "--data", off_csv, "--thresholds", ",".join(map(repr, r_true)), "--holdout", "0.25")
out = ok_json("pi offset", res)
if out:
    # Exact data of the model class: the least-squares optimum is the model (1e-8).
    check("pi offset weights", close(out["weights"], p_true, 1e-8), str(out["weights"]))
    descended = c_true + float(np.dot(p_true[1:], r_true))
    check("pi offset_um", abs(out["offset_um"] - descended) < 1e-8 and abs(out["rest_offset_um"] - c_true) < 1e-8,
          f'{out["offset_um"]} {out["rest_offset_um"]}')
    check("pi offset first fitted on the first descent", 50 < out["first_fitted"] < 150, str(out["first_fitted"]))
    check("pi offset validation", out["validation"]["samples"] == len(wave) // 4
          and out["validation"]["max_error"] < 1e-4 and out["poor_fit"] is False, json.dumps(out["validation"]))
    check("pi offset on stderr", "offset -" in res.stderr and "held out" in res.stderr, res.stderr)
# The same data without the offset term: a poor fit, exit 1, flagged in the JSON and on stderr.
res = run("identify", "pi", "--data", off_csv, "--thresholds", ",".join(map(repr, r_true)), "--no-offset")
check("pi poor fit exit 1", res.returncode == 1, f"exit {res.returncode}: {res.stderr}")
try:
    out = json.loads(res.stdout)
    check("pi poor fit flagged", out["poor_fit"] is True and out["fit"]["nrmse_percent"] > 10, json.dumps(out["fit"]))
except ValueError:
    check("pi poor fit JSON", False, res.stdout[:200])
check("pi poor fit on stderr", "poor fit" in res.stderr and "NRMSE" in res.stderr, res.stderr)

# Modified PI (output nonlinearity) on the same kind of data with a curved output.
ys = [v + 0.01 * (v + 118.0) ** 2 for v in yo]
res = run("identify", "pi", "--data", write_csv("curved.csv", ["u", "y"], [wave, ys]), "--thresholds",
          ",".join(map(repr, r_true)), "--output-nonlinearity", "4", "--holdout", "0.25")
out = ok_json("pi output nonlinearity", res)
if out:
    on = out["output_nonlinearity"]
    slopes_ok = all(s > 0 for s in on["inverse"]["slopes"]) and all(s > 0 for s in on["forward"]["slopes"])
    check("pi output nonlinearity reported", on["dead_zones"] == 4 and len(on["inverse"]["thresholds"]) == 4
          and slopes_ok and out["invertible"] is True, json.dumps(on))
    # Forward and inverse maps agree: slope products 1 on matching segments.
    check("pi output nonlinearity inverse", close([a * b for a, b in zip(on["inverse"]["slopes"], on["forward"]["slopes"])],
                                                 [1.0] * 5, 1e-12), json.dumps(on))
    check("pi output nonlinearity fits", out["validation"]["nrmse_percent"] < 1.0, json.dumps(out["validation"]))
    # The compensator, u = PI^-1(g(y) - c) in a scenario's pi_compensator
    # form, evaluated here independently (numpy, plays from rest) on the
    # data's own y: the input back within 2 % of its 3.6 V span (the fit's
    # held-out NRMSE is below 1 %, the inverse's slope about 0.5 V/um).
    k = out["compensator"]
    check("pi compensator form", k["kind"] == "pi_compensator" and len(k["dead_zones"]["thresholds_um"]) == 4
          and abs(k["input_offset_um"] + out["rest_offset_um"]) < 1e-6 * abs(out["rest_offset_um"]), json.dumps(k)[:300])
    d, q = np.array(k["dead_zones"]["thresholds_um"]), np.array(k["dead_zones"]["weights"])
    z, pz = np.array(k["thresholds_um"]), np.array(k["weights_V_per_um"])
    wz = np.zeros(len(z))
    u_hat = []
    for y in ys:
        f = y + float(np.dot(q, np.maximum(y - d, 0.0))) + k["input_offset_um"]
        wz = np.maximum(f - z, np.minimum(f + z, wz))
        u_hat.append(k["p0_V_per_um"] * f + float(np.dot(pz, wz)))
    first = out["first_fitted"]
    err = np.abs(np.array(u_hat[first:]) - wave[first:]).max()
    check("pi compensator inverts the data", err < 0.02 * 3.6, f"max |u_hat - u| {err:.4g} V")
    # A scenario takes it as its feedforward: float runs it, Q31 refuses its
    # thresholds (about -120 um) outside the position full scale, by name.
    sc = json.load(open(os.path.join(golden_dir, "..", "..", "configs", "stages", "strong_hysteresis.json")))
    sc["cases"] = [{"name": "compensated", "controller": {"feedforward": k}}]
    sc_file = os.path.join(tmp, "compensated.json")
    json.dump(sc, open(sc_file, "w"))
    res = run("sim", "--scenario", sc_file, "--case", "compensated", "--sample", "float", "--amplitude-um", "5",
              "--frequency-hz", "10")
    check("pi compensator in a scenario (float)", res.returncode == 0, res.stderr)
    falling = json.loads(json.dumps(sc))
    falling["cases"][0]["controller"]["feedforward"]["dead_zones"]["weights"][0] = -5.0
    json.dump(falling, open(os.path.join(tmp, "falling.json"), "w"))
    expect_error("pi compensator with a falling map, named as the file has it",
                 run("sim", "--scenario", os.path.join(tmp, "falling.json"), "--case", "compensated", "--amplitude-um",
                     "5", "--frequency-hz", "10"), "feedforward.dead_zones.weights[0]", "increasing")
    for name, zones, needle in (("unequal lists", {"thresholds_um": [-100.0, -90.0], "weights": [0.1]},
                                 "dead_zones.weights"),
                                ("nine dead zones", {"thresholds_um": [-100.0 + i for i in range(9)], "weights": [0.0] * 9},
                                 "dead_zones.thresholds_um"),
                                ("an unknown key", {"thresholds_um": [-100.0], "weights": [0.1], "slopes": [1.1]},
                                 "slopes")):
        bad_sc = json.loads(json.dumps(sc))
        bad_sc["cases"][0]["controller"]["feedforward"]["dead_zones"] = zones
        json.dump(bad_sc, open(os.path.join(tmp, "bad_zones.json"), "w"))
        expect_error(f"pi compensator dead zones: {name}",
                     run("sim", "--scenario", os.path.join(tmp, "bad_zones.json"), "--case", "compensated",
                         "--amplitude-um", "5", "--frequency-hz", "10"), needle)
    expect_error("pi compensator in Q31 beyond the scale",
                 run("sim", "--scenario", sc_file, "--case", "compensated", "--sample", "q31", "--amplitude-um", "5",
                     "--frequency-hz", "10"), "dead_zone_thresholds")

# The real recording, read raw (tab-separated, no header, fields 1 and 5):
# <repo>/../shared/data/piezo_micromanipulator, beside the repository.
real = os.path.join(os.path.dirname(os.path.abspath(__file__)), "..", "..", "..", "..", "shared", "data",
                    "piezo_micromanipulator")
if os.path.exists(os.path.join(real, "Model_Vi_Do.dat")):
    dat = os.path.join(real, "Model_Vi_Do.dat")
    raw = np.loadtxt(dat)
    y0 = float(open(os.path.join(real, "authors_model", "y0.dat")).read())
    # The authors' y0 is relative to the mean of the period from row 3152 (Step01_GetModel.m).
    reference = y0 + raw[3151:3351, 4].mean()
    res = run("identify", "pi", "--data", dat, "--columns", "u=1,y=5", "--operators", "16", "--holdout", "0.25",
              "--output-nonlinearity", "3")
    out = ok_json("pi real recording", res)
    if out:
        check("pi real held-out NRMSE <= 2 %", out["validation"]["nrmse_percent"] <= 2.0, json.dumps(out["validation"]))
        check("pi real offset within 1 %", abs(out["offset_um"] - reference) <= 0.01 * abs(reference),
              f'{out["offset_um"]} vs {reference}')
        print(f'     real recording: fit {out["fit"]["nrmse_percent"]:.2f} %, held out '
              f'{out["validation"]["nrmse_percent"]:.2f} %, offset {out["offset_um"]:.3f} um vs {reference:.3f} um')
        # Its compensator (numpy, plays from rest at the first sample) on the
        # sensor's readings gives back the command that moved the stage: on
        # the held-out periods within 1.5 % RMS of the 3.6 V span (0.63 %
        # measured; without the map g 5.3 %, without the offset 171 %).
        k = out["compensator"]
        d, q = np.array(k["dead_zones"]["thresholds_um"]), np.array(k["dead_zones"]["weights"])
        z, pz = np.array(k["thresholds_um"]), np.array(k["weights_V_per_um"])
        wz = np.zeros(len(z))
        u_hat = []
        for y in raw[:, 4]:
            f = y + float(np.dot(q, np.maximum(y - d, 0.0))) + k["input_offset_um"]
            wz = np.maximum(f - z, np.minimum(f + z, wz))
            u_hat.append(k["p0_V_per_um"] * f + float(np.dot(pz, wz)))
        held = len(raw) - out["validation"]["samples"]
        rms = float(np.sqrt(np.mean((np.array(u_hat[held:]) - raw[held:, 0]) ** 2)))
        check("pi real compensator gives the command back", rms <= 0.015 * 3.6, f"RMS {rms:.4g} V")
        print(f'     real recording: the compensator on the held-out readings, command RMS error {rms:.4f} V '
              f'({100 * rms / 3.6:.2f} % of 3.6 V)')
    bad_dat = os.path.join(tmp, "real_nan.dat")
    lines = open(dat).read().splitlines()
    lines[99] = lines[99].replace(lines[99].split("\t")[4], "nan")
    open(bad_dat, "w").write("\n".join(lines) + "\n")
    expect_error("real nan", run("identify", "pi", "--data", bad_dat, "--columns", "u=1,y=5"),
                 "real_nan.dat:100:", "column 'y' (field 5)", "not finite")
    expect_error("real field out of range", run("identify", "pi", "--data", dat, "--columns", "u=1,y=9"),
                 "Model_Vi_Do.dat:1:", "column 'y' (field 9)", "only 7 fields")
    expect_error("real header expected", run("identify", "pi", "--data", dat), "Model_Vi_Do.dat:1:", "header")
else:
    print(f"SKIP real recording: no {real}/Model_Vi_Do.dat (the shared folder sits beside the repository in CI)")

# ------------------------------------------------------------------ dahl
# Voltages that make the Dahl plant follow a prescribed displacement path
# (RK4 on dz/dx with 100 sub-steps per sample), published set in the unit
# convention with visible hysteresis: dahl_params_in_units(kAhmad2020Dahl, 1e-5, 1).
a1, a2, b1, b2, gam, ga = 1.76e3 * 1e-5, 3.46e7 * 1e-10, 0.0, 3.11e7, 30.0 * 1e-10, 0.925
# As floats (the parameters the core holds), so the check compares like with like.
a1, a2, gam = float(np.float32(a1)), float(np.float32(a2)), float(np.float32(gam))
b2, ga = float(np.float32(b2)), float(np.float32(ga))
xs = list(np.linspace(0, 30, 201)) + list(np.linspace(30, 8, 151)[1:]) + list(np.linspace(8, 30, 151)[1:]) \
    + list(np.linspace(30, 8, 151)[1:])
z1 = z2 = 0.0
s = 1
vs = [xs[0] / ga]
for k in range(1, len(xs)):
    dx = xs[k] - xs[k - 1]
    s = -1 if dx < 0 else 1
    h = dx / 100

    def f(y1, y2):
        return y2, -a2 * y1 - a1 * s * y2 + gam
    for _ in range(100):
        k1 = f(z1, z2)
        k2 = f(z1 + h / 2 * k1[0], z2 + h / 2 * k1[1])
        k3 = f(z1 + h / 2 * k2[0], z2 + h / 2 * k2[1])
        k4 = f(z1 + h * k3[0], z2 + h * k3[1])
        z1 += h / 6 * (k1[0] + 2 * k2[0] + 2 * k3[0] + k4[0])
        z2 += h / 6 * (k1[1] + 2 * k2[1] + 2 * k3[1] + k4[1])
    vs.append((xs[k] + b2 * z1 + s * b1 * z2) / ga)
dahl_csv = write_csv("dahl.csv", ["v_V", "x_um"], [vs, xs])
out = ok_json("dahl", run("identify", "dahl", "--data", dahl_csv, "--input", "v_V", "--output", "x_um",
                          "--gamma-a", repr(gam)))
if out:
    q = out["params"]
    # Noise-free data from the same model: the optimum is the truth up to the
    # RK4 error (< 1e-10 of the range) and the LM stopping tolerance; 1e-5 relative.
    ok = all(abs(q[k] - t) <= 1e-5 * abs(t) for k, t in
             (("alpha1", a1), ("alpha2", a2), ("beta2", b2), ("ga", ga)))
    check("dahl params", ok and q["gamma_a"] == gam and abs(q["beta1"]) < 1e-5 * b2 / math.sqrt(a2),
          json.dumps(q))
    check("dahl fit", out["fit"]["rms_error"] < 1e-6 and out["gamma_a_held"] is True, json.dumps(out["fit"]))
    check("dahl offset", out["offset_fitted"] is True and abs(out["offset_um"]) < 1e-6 and out["poor_fit"] is False,
          str(out["offset_um"]))

# The real recording starts mid-loop (1.8 V, after a rest at 0 V): the
# default fit starts at the first turning point with the model's start
# estimated (the virgin state at a fitted voltage). Figures on 2026-11-27:
# 2.52 % fitted, 2.69 % held out, offset -119.22 um against the authors'
# -118.90 um, virgin at -0.19 V; from the virgin state at the first sample
# the fit is refused (alpha2's standard error), as it was before.
if os.path.exists(os.path.join(real, "Model_Vi_Do.dat")):
    res = run("identify", "dahl", "--data", dat, "--columns", "v=1,x=5", "--holdout", "0.25")
    out = ok_json("dahl real recording", res)
    if out:
        # Held-out NRMSE within 3 % (the PI model's is 2.5 %); the offset as
        # for identify pi within 1 % of the authors'; the start at the rest
        # before the record (0 V) within 0.5 V, 14 % of the command span.
        check("dahl real held-out NRMSE <= 3 %", out["validation"]["nrmse_percent"] <= 3.0 and not out["poor_fit"],
              json.dumps(out["validation"]))
        check("dahl real offset within 1 %", abs(out["offset_um"] - reference) <= 0.01 * abs(reference),
              f'{out["offset_um"]} vs {reference}')
        check("dahl real start", out["first_fitted"] == 50 and abs(out["virgin_V"]) <= 0.5, json.dumps(out["virgin_V"]))
        print(f'     real recording, Dahl: fit {out["fit"]["nrmse_percent"]:.2f} %, held out '
              f'{out["validation"]["nrmse_percent"]:.2f} %, offset {out["offset_um"]:.3f} um, virgin at '
              f'{out["virgin_V"]:.3f} V')
    expect_error("dahl real from the virgin state",
                 run("identify", "dahl", "--data", dat, "--columns", "v=1,x=5", "--first-fitted", "0",
                     "--start-state", "virgin"),
                 "v: the data cannot identify the Dahl parameters", "start_state estimated")

# ------------------------------------------------------------------ reduce
b = json.load(open(f"{golden_dir}/ident_balred.json"))
hsv_ref = b["cases"][0]["hsv"]  # Janaideh2016 D(s)
model = {"series": [{"num": [-20.7], "den": [1.0]},
                    {"num": [1.0, 1430.0], "den": [1.0, 925.0, 4.59e5]},
                    {"num": list(np.polymul([1.0, -2.776e4], [1.0, -1.07e4])), "den": [1.0, 55.0, 1.4e7]},
                    {"num": [1.0, 4.3e4, 3.2e9], "den": [1.0, 1.54e4, 4e9]},
                    {"num": list(np.polymul([1.0, -1.22e5], [1.0, 2.99e4])), "den": [1.0, 964.0, 3.95e9]}]}
model_path = os.path.join(tmp, "janaideh_D.json")
json.dump(model, open(model_path, "w"))
out = ok_json("reduce", run("reduce", "--model", model_path, "--order", "6"))
if out:
    # HSVs do not depend on the realisation: scipy's on another realisation,
    # 1e-7 sigma_1 (test_balred.cpp holds its own realisations to 1e-9).
    check("reduce hsv", close(out["hsv"], hsv_ref, 1e-7 * hsv_ref[0]), str(out["hsv"]))
    check("reduce bound", abs(out["error_bound"] - b["cases"][0]["reduced"][1]["bound"]) < 1e-8,
          str(out["error_bound"]))
    m = out["model"]
    check("reduce model", out["order"] == 6 and out["original_order"] == 8 and len(m.get("poles", [])) == 6,
          json.dumps(m)[:300])

# ------------------------------------------------------------------ errors
expect_error("missing column", run("identify", "rls", "--data", arx_csv, "--output", "x_um"),
             "x_um: no such column", "t, u, y")
expect_error("missing file", run("identify", "pi", "--data", os.path.join(tmp, "nope.csv")), "cannot open")
bad = os.path.join(tmp, "bad.csv")
open(bad, "w").write("t,u,y\n0,1,2\n1,nan,3\n")
expect_error("nan in csv", run("identify", "rls", "--data", bad), "bad.csv:3:", "column 'u'", "not finite")
open(bad, "w").write("t,u,y\n0,1,2\n1,x,3\n")
expect_error("text in csv", run("identify", "pi", "--data", bad), "bad.csv:3:", "column 'u'", "not a number")
open(bad, "w").write("t,u,y\n0,1,2\n1,2\n")
expect_error("short row", run("identify", "dahl", "--data", bad, "--input", "u", "--output", "y"),
             "bad.csv:3:", "expected 3 fields")
flat = write_csv("flat.csv", ["t", "u", "y"], [g["t"], [1.0] * len(g["t"]), g["y"]])
expect_error("no excitation", run("identify", "rls", "--data", flat), "u: no excitation")
expect_error("no excitation pi", run("identify", "pi", "--data", flat), "u: no excitation")
jit = write_csv("jitter.csv", ["t", "u", "y"], [[0, 1, 2, 4] + list(range(5, 100)), g["u"][:99], g["y"][:99]])
expect_error("non-uniform time", run("identify", "rls", "--data", jit), "jitter.csv:5:", "column 't'", "not uniform")
expect_error("no time column", run("identify", "rls", "--data", named_csv, "--input", "v_V", "--output", "x_um"),
             "ts:", "--ts")
expect_error("far threshold", run("identify", "pi", "--data", set15_csv, "--thresholds", "1,50", *plain),
             "thresholds[1]", "never reached")
expect_error("threshold never forgets", run("identify", "pi", "--data", set15_csv, "--thresholds", "1,50"),
             "thresholds[1]", "never moves by 2 r = 100", "first fitted")
expect_error("descending thresholds", run("identify", "pi", "--data", set15_csv, "--thresholds", "2,1"),
             "thresholds[1]")
expect_error("operators range", run("identify", "pi", "--data", set15_csv, "--operators", "17"), "--operators")
expect_error("dahl start", run("identify", "dahl", "--data", dahl_csv, "--input", "v_V", "--output", "x_um",
                               "--start", "1,2,3"), "start: needs 5 values")
expect_error("dahl columns", run("identify", "dahl", "--data", dahl_csv), "v: no such column")
expect_error("dahl first-fitted", run("identify", "dahl", "--data", dahl_csv, "--input", "v_V", "--output", "x_um",
                                      "--first-fitted", "soon"), "first-fitted")
expect_error("dahl holdout range", run("identify", "dahl", "--data", dahl_csv, "--input", "v_V", "--output", "x_um",
                                        "--holdout", "0.95"), "--holdout")
expect_error("dahl start state", run("identify", "dahl", "--data", dahl_csv, "--input", "v_V", "--output", "x_um",
                                      "--start-state", "rest"), "--start-state")
expect_error("dahl first-fitted beyond", run("identify", "dahl", "--data", dahl_csv, "--input", "v_V", "--output",
                                             "x_um", "--first-fitted", "100000"), "first_fitted: 100000 is not below")
expect_error("columns syntax", run("identify", "pi", "--data", off_csv, "--columns", "u=0,y=2"), "columns: 'u=0'")
expect_error("columns twice", run("identify", "pi", "--data", off_csv, "--columns", "u=1,u=2"), "named twice")
expect_error("first-fitted", run("identify", "pi", "--data", off_csv, "--first-fitted", "soon"), "first-fitted")
expect_error("holdout range", run("identify", "pi", "--data", off_csv, "--holdout", "0.95"), "--holdout")
expect_error("too few samples", run("identify", "pi", "--data", write_csv("few.csv", ["u", "y"],
             [wave[:30], yo[:30]]), "--first-fitted", "0"), "u: too short")
expect_error("dead zones range", run("identify", "pi", "--data", off_csv, "--output-nonlinearity", "9"),
             "--output-nonlinearity")
unstable = os.path.join(tmp, "unstable.json")
json.dump({"num": [1.0], "den": [1.0, -1.0]}, open(unstable, "w"))
expect_error("reduce unstable", run("reduce", "--model", unstable, "--order", "1"), "not stable")
expect_error("reduce order", run("reduce", "--model", model_path, "--order", "9"), "order")
expect_error("reduce missing model", run("reduce", "--model", os.path.join(tmp, "none.json"), "--order", "2"),
             "none.json")
bad_model = os.path.join(tmp, "bad_model.json")
open(bad_model, "w").write('{"num": [1.0], "den": [0.0, 1.0]}')
expect_error("reduce bad model", run("reduce", "--model", bad_model, "--order", "1"), "den")

print(f"{passed} passed, {failed} failed")
sys.exit(1 if failed else 0)
