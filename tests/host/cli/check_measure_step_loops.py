#!/usr/bin/python3
"""End-to-end checks of `piezoloop measure step` and `piezoloop measure loops`
on the simulator (docs/measurement.md), on the Ahmad2020 stage with
its sensor noise and 16-bit converters on.

1. Open-loop step, command 3 V -> 5 V (piezo 30 -> 50 V): the stage rises
   monotonically from rest, so its hysteresis stays on the PI loading curve
   y = p0 v + sum_j w_j max(0, v - r_j) (v the piezo voltage, 10 x the
   command; DC gain of the dynamics normalised to 1): the initial and final
   values must equal that curve at 30 V and 50 V to 0.01 um (the sensor's
   noise, 1.5 nm rms, is averaged over 100+ samples; the ADC's step is
   0.46 nm). The figures are recomputed here from the arrays in step.json
   (independent code, same definitions) and must agree to 1e-9.
2. Closed-loop step (case dahl_ff_K) 3 -> 8 um: settled, final value within
   0.02 um of 8 um (its controller has integral action); figures recomputed.
3. Loops 2.5, 5, 7.5, 10 V at 2 Hz, then `identify pi` on the CSV: the PI
   model fitted from the measured loops reproduces them within 1 % of the
   output range (the acceptance check), both by the fit's own max_error and by
   running the fitted model here (play operators from zero, as pi_fit.hpp)
   on the CSV's u; the hysteresis % per amplitude recomputed here at the
   input midpoint of the last cycle. `identify dahl` reads the same CSV.
4. Hostile requests: exit 2, the option named, no file written.
Usage: check_measure_step_loops.py PIEZOLOOP_BINARY CONFIGS_DIR"""
import csv
import json
import math
import os
import subprocess
import sys
import tempfile

import numpy as np

exe, configs = sys.argv[1], sys.argv[2]
tmp = tempfile.mkdtemp(prefix="piezoloop_step_loops_")
scenario = os.path.join(configs, "ahmad2020.json")
failed = 0


def check(name, ok, detail=""):
    global failed
    print(("ok   " if ok else "FAIL ") + name + (f": {detail}" if detail else ""))
    if not ok:
        failed += 1


def run(*args):
    return subprocess.run([exe, *args], capture_output=True, text=True)


def step_figures(t, y):
    """Same definitions as host/measure/step_response.hpp, written again."""
    pre = t < 0
    y0 = y[pre].mean()
    post_t, post_y = t[~pre], y[~pre]
    tail = max(1, int(0.1 * len(post_y)))
    yf = post_y[-tail:].mean()
    z = (post_y - y0) / (yf - y0)
    ts = post_t[1] - post_t[0]

    def cross(level):
        i = int(np.argmax(z >= level))
        return post_t[i] if i == 0 else post_t[i - 1] + (level - z[i - 1]) / (z[i] - z[i - 1]) * ts

    out = np.nonzero(np.abs(z - 1) > 0.02)[0]
    if len(out) == 0:
        settle = 0.0
    else:
        i = out[-1]
        edge = 1.02 if z[i] > 1 else 0.98
        settle = post_t[i] + (edge - z[i]) / (z[i + 1] - z[i]) * ts
    return {"initial_um": y0, "final_value_um": yf, "overshoot_pct": max(0.0, (z.max() - 1) * 100),
            "rise_time_s": cross(0.9) - cross(0.1), "settling_time_s": settle}


stage = json.load(open(scenario))["plant"]["hysteresis"]


def loading_curve(v):
    return stage["p0_um_per_V"] * v + sum(w * max(0.0, v - r) for w, r in zip(stage["weights_um_per_V"],
                                                                               stage["thresholds_V"]))


# 1. Open-loop step.
out = os.path.join(tmp, "step.json")
res = run("measure", "step", "--scenario", scenario, "--step-v", "2", "--bias-v", "3", "--out", out,
          "--csv", os.path.join(tmp, "step.csv"))
check("measure step (open loop) runs", res.returncode == 0, res.stderr)
if res.returncode == 0:
    print("     " + res.stderr.strip())
    j = json.load(open(out))
    t, y = np.array(j["time_s"]), np.array(j["response_um"])
    for key in ("overshoot_pct", "rise_time_s", "settling_time_s", "final_value_um", "command_V", "warnings"):
        check(f"step.json has {key}", key in j)
    check("command steps 3 -> 5 V", j["command_V"][0] == 3.0 and j["command_V"][-1] == 5.0)
    mine = step_figures(t, y)
    for k, v in mine.items():
        check(f"open loop {k} recomputed", abs(j[k] - v) <= 1e-9 * max(1.0, abs(v)), f"{j[k]} vs {v}")
    y30, y50 = loading_curve(30.0), loading_curve(50.0)
    check("initial value on the loading curve at 30 V", abs(j["initial_um"] - y30) <= 0.01,
          f"{j['initial_um']:.4f} vs {y30:.4f} um")
    check("final value on the loading curve at 50 V", abs(j["final_value_um"] - y50) <= 0.01,
          f"{j['final_value_um']:.4f} vs {y50:.4f} um")
    print(f"     open loop: overshoot {j['overshoot_pct']:.1f} %, rise {1e3 * j['rise_time_s']:.3f} ms, "
          f"settling {1e3 * j['settling_time_s']:.2f} ms")
    rows = list(csv.DictReader(open(os.path.join(tmp, "step.csv"))))
    check("step.csv holds the record", len(rows) == len(t) and set(rows[0]) == {"t", "r", "u", "y"})

# 2. Closed-loop step.
res = run("measure", "step", "--scenario", scenario, "--case", "dahl_ff_K", "--step-um", "5", "--from-um", "3",
          "--out", out)
check("measure step (closed loop) runs", res.returncode == 0, res.stderr)
if res.returncode == 0:
    j = json.load(open(out))
    mine = step_figures(np.array(j["time_s"]), np.array(j["response_um"]))
    for k, v in mine.items():
        check(f"closed loop {k} recomputed", abs(j[k] - v) <= 1e-9 * max(1.0, abs(v)), f"{j[k]} vs {v}")
    check("closed loop settles", j["settled"] and not j["warnings"], str(j["warnings"]))
    check("closed loop final value 8 um", abs(j["final_value_um"] - 8.0) <= 0.02, str(j["final_value_um"]))
    print(f"     closed loop: overshoot {j['overshoot_pct']:.1f} %, rise {1e3 * j['rise_time_s']:.3f} ms, "
          f"settling {1e3 * j['settling_time_s']:.2f} ms")

# 3. Loops and the PI model fitted to them.
loops_csv, loops_json = os.path.join(tmp, "loops.csv"), os.path.join(tmp, "loops.json")
amplitudes = [2.5, 5.0, 7.5, 10.0]
res = run("measure", "loops", "--scenario", scenario, "--amplitudes-v", ",".join(map(str, amplitudes)),
          "--frequency-hz", "2", "--cycles", "2", "--out", loops_csv, "--json", loops_json)
check("measure loops runs", res.returncode == 0, res.stderr)
if res.returncode == 0:
    print("     " + res.stderr.strip())
    summary = json.load(open(loops_json))
    data = np.genfromtxt(loops_csv, delimiter=",", names=True)
    u, y = data["u"], data["y"]
    check("CSV columns for identify pi and dahl", set(data.dtype.names) >= {"t", "u", "y", "v", "x"})
    check("no warnings", not summary["warnings"], str(summary["warnings"]))
    cycle = 5000  # 2 Hz at 10 kHz
    for i, loop in enumerate(summary["loops"]):
        # The amplitude's rows pair u_k with y_k+1 within its own recording,
        # so its last cycle is its last cycle - 1 rows.
        rows = np.nonzero(data["amplitude_V"] == amplitudes[i])[0]
        lu, ly = u[rows][-(cycle - 1):], y[rows][-(cycle - 1):]
        vm = 0.5 * (lu.min() + lu.max())
        up = next(k for k in range(len(lu) - 1) if lu[k] < vm <= lu[k + 1])
        dn = next(k for k in range(len(lu) - 1) if lu[k] > vm >= lu[k + 1])
        x_at = lambda k: ly[k] + (vm - lu[k]) / (lu[k + 1] - lu[k]) * (ly[k + 1] - ly[k])
        h = 100 * abs(x_at(up) - x_at(dn)) / (ly.max() - ly.min())
        check(f"hysteresis at {amplitudes[i]} V recomputed", abs(loop["hysteresis_pct"] - h) <= 1e-6,
              f"{loop['hysteresis_pct']:.4f} vs {h:.4f} %")
        print(f"     {amplitudes[i]:>4} V: hysteresis {loop['hysteresis_pct']:.2f} %, widest "
              f"{loop['max_width_pct']:.2f} %, y {loop['y_min_um']:.2f} .. {loop['y_max_um']:.2f} um")
    # y = PI[u] from rest over every sample, as the model is rerun below.
    res = run("identify", "pi", "--data", loops_csv, "--no-offset", "--first-fitted", "0")
    check("identify pi reads the loops", res.returncode == 0, res.stderr)
    if res.returncode == 0:
        fit = json.loads(res.stdout)
        span = y.max() - y.min()
        own = fit["fit"]["max_error"] / span
        # The fitted model run here: plays from zero, y = sum_j w_j F_rj[u].
        z = np.zeros(len(fit["thresholds"]))
        r = np.array(fit["thresholds"])
        w = np.array(fit["weights"])
        model = np.empty_like(u)
        for k, uk in enumerate(u):
            z = np.maximum(uk - r, np.minimum(uk + r, z))
            model[k] = w @ z
        mine = np.abs(model - y).max() / span
        print(f"     identify pi: max error {fit['fit']['max_error']:.4f} um = {100 * own:.3f} % of the "
              f"{span:.2f} um range (rerun here: {100 * mine:.3f} %)")
        check("PI fitted from the loops reproduces them within 1 % of range (fit's max_error)", own <= 0.01,
              f"{100 * own:.3f} %")
        check("... and when run here", mine <= 0.01 and abs(mine - own) <= 1e-4, f"{100 * mine:.3f} %")
    short_csv = os.path.join(tmp, "short.csv")
    res = run("measure", "loops", "--scenario", scenario, "--amplitudes-v", "5,10", "--frequency-hz", "20",
              "--out", short_csv)
    res = run("identify", "dahl", "--data", short_csv) if res.returncode == 0 else res
    check("identify dahl reads the loops", res.returncode == 0, res.stderr[-300:])

# 4. Hostile requests.
step_good = ["--scenario", scenario, "--step-v", "1", "--bias-v", "3"]
hostile = [
    ("step beyond the limits", ["step", "--scenario", scenario, "--step-v", "10", "--bias-v", "3"], "--step-v"),
    ("negative step below the limits", ["step", "--scenario", scenario, "--step-v", "-6", "--bias-v", "3"],
     "--step-v"),
    ("bias beyond the limits", ["step", "--scenario", scenario, "--step-v", "1", "--bias-v", "13"], "--bias-v"),
    ("NaN step", ["step", "--scenario", scenario, "--step-v", "nan"], "--step-v"),
    ("zero step", ["step", "--scenario", scenario, "--step-v", "0"], "--step-v"),
    ("zero duration", ["step", *step_good, "--duration-s", "0"], "--duration-s"),
    ("negative duration", ["step", *step_good, "--duration-s", "-1"], "--duration-s"),
    ("NaN duration", ["step", *step_good, "--duration-s", "nan"], "--duration-s"),
    ("reference step beyond the range",
     ["step", "--scenario", scenario, "--case", "dahl_ff_K", "--step-um", "40"], "--step-um"),
    ("setpoint beyond the range",
     ["step", "--scenario", scenario, "--case", "dahl_ff_K", "--step-um", "1", "--from-um", "-3"], "--from-um"),
    ("closed loop without a case", ["step", "--scenario", scenario, "--step-um", "1"], "--case"),
    ("both steps", ["step", *step_good, "--step-um", "1"], "--step-um"),
    ("loop amplitude beyond the limits", ["loops", "--scenario", scenario, "--amplitudes-v", "10,20,30,40"],
     "--amplitudes-v"),
    ("NaN loop amplitude", ["loops", "--scenario", scenario, "--amplitudes-v", "5,nan"], "--amplitudes-v"),
    ("zero loop amplitude", ["loops", "--scenario", scenario, "--amplitudes-v", "0"], "--amplitudes-v"),
    ("zero frequency", ["loops", "--scenario", scenario, "--amplitudes-v", "5", "--frequency-hz", "0"],
     "--frequency-hz"),
    ("zero cycles", ["loops", "--scenario", scenario, "--amplitudes-v", "5", "--cycles", "0"], "--cycles"),
    # A frequency near 0: the duration is checked before it is counted in
    # ticks (which would overflow).
    ("frequency near 0", ["loops", "--scenario", scenario, "--amplitudes-v", "5", "--frequency-hz", "1e-15",
                          "--cycles", "2"], "--frequency-hz"),
    ("loops beyond the longest record", ["loops", "--scenario", scenario, "--amplitudes-v", "1,2,3",
                                         "--frequency-hz", "0.01", "--cycles", "10"], "--frequency-hz"),
]
for name, args, option in hostile:
    target = os.path.join(tmp, "hostile.out")
    if os.path.exists(target):
        os.remove(target)
    res = run("measure", *args, "--out", target)
    check(f"refused: {name}", res.returncode == 2 and option in res.stderr and not os.path.exists(target),
          f"exit {res.returncode}: {res.stderr.strip()}")

print("check_measure_step_loops: " + ("FAILED" if failed else "all passed"))
sys.exit(1 if failed else 0)
