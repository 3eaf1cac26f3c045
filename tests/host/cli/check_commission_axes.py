#!/usr/bin/python3
"""`piezoloop commission --scenario S --axes ...` on the shipped stages of
coupled axes (configs/stages/xy_flexure.json, xyz_flexure.json):

- every axis verifies and the stage is decoupled;
- the coupling measured before the output matrix equals the scenario's own
  coupling paths (their DC gain, in dB, within 0.5 dB: the paths are the
  only coupling, and at 10-30 Hz |G_ij| / |G_jj| is the path's DC gain to
  O(f^2) of its 750-850 Hz mode, 0.02 dB);
- the output matrix equals G0^-1 diag(G0) for the static gain the scenario
  states (slope p0 times the amplifier's gain per axis, the paths' DC gains
  off the diagonal) within 2 % (the 1 %-of-span excitation stays below the
  first play threshold, so the stage answers at p0; the estimate's noise
  and the sensor lag make the rest);
- every measured pair's coupling drops by >= 20 dB, and a 10 Hz triangle on
  each axis moves every other axis by <= 0.1 % of its range;
- DIR/scenario.json reproduces the check: `piezoloop sim --hash` of its
  case commissioned gives the log hash the command reported;
- refusals exit 2 naming the option, nothing written.
Usage: check_commission_axes.py PIEZOLOOP_BINARY CONFIGS_DIR"""
import json
import math
import os
import subprocess
import sys
import tempfile

import numpy as np

exe, configs = sys.argv[1], sys.argv[2]
passed = failed = 0


def check(name, ok, detail=""):
    global passed, failed
    if ok:
        passed += 1
    else:
        failed += 1
        print(f"FAIL {name} {detail}")


def run(args):
    return subprocess.run([exe, "commission"] + args, capture_output=True, text=True, timeout=600)


def stated_static_gain(scenario):
    """G0 from the scenario file: the command -> µm slope p0 x amplifier gain on
    the diagonal, the coupling paths' DC gain times the source axis's slope."""
    axes = scenario["plant"]["axes"]
    names = [a["name"] for a in axes]
    g = [a["hysteresis"]["p0_um_per_V"] * a["amplifier"]["gain"] for a in axes]
    g0 = np.diag(g)
    for p in scenario["plant"].get("coupling", []):
        i, j = names.index(p["to"]), names.index(p["from"])
        g0[i, j] = p["dc_gain"] * g[j]
    return names, g0


with tempfile.TemporaryDirectory() as tmp:
    runs = {"xy_flexure": ["--axes", "x,y", "--range-um", "80"],
            "xyz_flexure": ["--axes", "all", "--range-um", "x=80,y=80,z=10"]}
    for name, args in runs.items():
        path = os.path.join(configs, "stages", name + ".json")
        with open(path) as f:
            scenario = json.load(f)
        out = os.path.join(tmp, name)
        res = run(["--scenario", path, "--out", out] + args)
        check(f"{name}: exit 0", res.returncode == 0, res.stderr[-2000:])
        if res.returncode != 0:
            continue
        s = json.loads(res.stdout)
        check(f"{name}: every axis verified", s["verified"] and all(a["verified"] for a in s["axes"].values()))
        check(f"{name}: decoupled", s["decoupled"] is True)
        for f in ["scenario.json", "report.md"] + [os.path.join(a, "report.md") for a in s["axes"]]:
            check(f"{name}: {f} written", os.path.getsize(os.path.join(out, f)) > 0)
        names, g0 = stated_static_gain(scenario)
        c = s["coupling"]
        for pair, before in c["before_db"].items():
            i, j = (names.index(a) for a in pair.split("<-"))
            stated = g0[i, j] / g0[j, j]
            if stated > 0:
                check(f"{name}: {pair} measured as the scenario states", abs(before - 20 * math.log10(stated)) < 0.5,
                      f"{before:.2f} dB vs {20 * math.log10(stated):.2f} dB")
                check(f"{name}: {pair} reduced by >= 20 dB", c["reduction_db"][pair] >= 20.0, c["reduction_db"][pair])
            else:
                check(f"{name}: {pair} (no path) not measured", pair in c["not_measured"], c["not_measured"])
        d = np.array(s["output_matrix"])
        d_stated = np.linalg.solve(g0, np.diag(np.diag(g0)))
        check(f"{name}: output matrix as the stated G0 gives", np.max(np.abs(d - d_stated)) < 0.02,
              f"{d.tolist()} vs {d_stated.tolist()}")
        for axis, k in s["check"]["axes"].items():
            for held, pct in k["cross_motion_pct"].items():
                check(f"{name}: 10 Hz on {axis} moves {held} by <= 0.1 %", pct <= 0.1, pct)
            print(f"{name}: 10 Hz on {axis}: e_max {k['e_max_pct']:.3f} %, cross motion "
                  + ", ".join(f"{h} {p:.4f} % (without D {k['cross_motion_pct_without_decoupling'][h]:.4f} %)"
                              for h, p in k["cross_motion_pct"].items()))
        print(f"{name}: coupling before {c['before_db']}, reduction {c['reduction_db']}")
        # The written scenario reproduces the check run for the first axis.
        first = names[0]
        centre = {a: s["axes"][a]["centre_um"] for a in names}
        sim = subprocess.run([exe, "sim", "--scenario", s["scenario_file"], "--case", "commissioned", "--axis", first,
                              "--frequency-hz", "10", "--amplitude-um", str(80.0), "--midpoint-um", repr(centre[first]),
                              "--hash"] + sum((["--hold-um", f"{a}={centre[a]:.6f}"] for a in names[1:]), []),
                             capture_output=True, text=True)
        check(f"{name}: scenario.json reproduces the check's hash",
              sim.returncode == 0 and sim.stdout.strip() == s["check"]["axes"][first]["log_hash"],
              f"{sim.stdout.strip()} vs {s['check']['axes'][first]['log_hash']}: {sim.stderr[-500:]}")

    xy = os.path.join(configs, "stages", "xy_flexure.json")
    refusals = [
        (["--scenario", xy, "--axes", "x", "--range-um", "80"], "--axes"),
        (["--scenario", xy, "--axes", "x,x", "--range-um", "80"], "--axes"),
        (["--scenario", xy, "--axes", "x,q", "--range-um", "80"], "--axes"),
        (["--scenario", xy, "--axes", "x,y", "--range-um", "x=80"], "--range-um"),
        (["--scenario", xy, "--axes", "x,y", "--range-um", "x=80,q=3"], "--range-um"),
        (["--scenario", xy, "--axes", "x,y", "--range-um", "abc"], "--range-um"),
        (["--scenario", xy, "--range-um", "80"], "--axes"),
        (["--scenario", os.path.join(configs, "ahmad2020.json"), "--axes", "x", "--range-um", "8"], "--axes"),
    ]
    for args, option in refusals:
        out = os.path.join(tmp, "refused")
        res = run(args + ["--out", out])
        check(f"refused {args[2:]}", res.returncode == 2 and option in res.stderr and not os.path.exists(out),
              f"exit {res.returncode}: {res.stderr.strip()[-300:]}")

print(f"{passed} passed, {failed} failed")
sys.exit(1 if failed else 0)
