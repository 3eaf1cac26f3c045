#!/usr/bin/python3
"""End-to-end check of `piezoloop design musyn` (D–K iteration,
docs/synthesis.md) on a 5-state problem with --iterations 2 (well under a
second): the JSON fields, μ not rising from the pure H∞ iterate, the
controller file, the nominal loop evaluated here with numpy, and the error
paths (2: bad input naming the option or model; missing --hm).
Usage: check_design_musyn.py PIEZOLOOP_BINARY
"""
import json
import os
import subprocess
import sys
import tempfile

import numpy as np

exe = sys.argv[1]
passed = failed = 0


def check(ok, what):
    global passed, failed
    if ok:
        passed += 1
    else:
        failed += 1
        print("FAIL", what)


def zpk_at(m, s):
    z = [complex(*r) if isinstance(r, list) else complex(r) for r in m["zeros"]]
    p = [complex(*r) if isinstance(r, list) else complex(r) for r in m["poles"]]
    return m["gain"] * np.prod([s - r for r in z]) / np.prod([s - r for r in p])


tmp = tempfile.mkdtemp()


def model(name, zeros, poles, gain):
    path = os.path.join(tmp, name + ".json")
    with open(path, "w") as f:
        json.dump({"zeros": zeros, "poles": poles, "gain": gain}, f)
    return path


g = model("g", [], [-1, -50], 500)
w1 = model("w1", [-20], [-0.02], 0.5)
hm = model("hm", [-10], [-200], 0.5)
w3 = model("w3", [-10], [-1000], 5)
out = os.path.join(tmp, "k.json")

r = subprocess.run([exe, "design", "musyn", "--plant", g, "--w1", w1, "--w3", w3, "--hm", hm,
                    "--iterations", "2", "--d-order", "1", "--out", out], capture_output=True, text=True)
check(r.returncode == 0, "musyn: %d %s" % (r.returncode, r.stderr))
if r.returncode == 0:
    j = json.loads(r.stdout)
    for key in ("gamma", "controller", "stable", "order", "iterations", "rp_peak", "rs_peak", "np_peak"):
        check(key in j, "field " + key)
    its = j["iterations"]
    check(1 <= len(its) <= 2, "iterations %d" % len(its))
    check("iteration 1: gamma" in r.stderr, "progress on stderr")
    check(all(b["mu_peak"] <= a["mu_peak"] for a, b in zip(its, its[1:])), "mu rose: %s" % its)
    check(j["rp_peak"]["value"] <= its[0]["mu_peak"] * 1.02, "rp %g vs first %g" % (j["rp_peak"]["value"], its[0]["mu_peak"]))
    check(j["stable"] and j["rp_peak"]["value"] < 1.0, "robust performance %s" % j["rp_peak"])
    # RS peak = max |H_m T| recomputed here on a grid (a lower bound of the refined peak).
    k = json.load(open(out))
    check(k["gain"] == j["controller"]["gain"] and "musyn" in k["description"], "controller file")
    G = json.load(open(g)); H = json.load(open(hm))
    rs = 0.0
    for w in np.logspace(-2, 4, 2000):
        s = 1j * w
        L = zpk_at(G, s) * zpk_at(j["controller"], s)
        rs = max(rs, abs(zpk_at(H, s) * L / (1 + L)))
    check(rs <= j["rs_peak"]["value"] * (1 + 1e-6) and rs > 0.98 * j["rs_peak"]["value"],
          "rs %g vs %g" % (rs, j["rs_peak"]["value"]))

r = subprocess.run([exe, "design", "musyn", "--plant", g, "--w1", w1, "--w3", w3], capture_output=True, text=True)
check(r.returncode != 0 and "--hm" in r.stderr and r.stdout == "", "no --hm: %d %s" % (r.returncode, r.stderr))
bad = model("bad", [-10], [1], 5)
r = subprocess.run([exe, "design", "musyn", "--plant", g, "--w1", w1, "--w3", bad, "--hm", hm], capture_output=True, text=True)
check(r.returncode == 2 and "w3: weight is unstable" in r.stderr, "unstable w3: %d %s" % (r.returncode, r.stderr))
r = subprocess.run([exe, "design", "musyn", "--plant", g, "--w1", w1, "--hm", hm, "--iterations", "0"],
                   capture_output=True, text=True)
check(r.returncode == 2 and "--iterations" in r.stderr, "iterations 0: %d %s" % (r.returncode, r.stderr))

print("%d passed, %d failed" % (passed, failed))
sys.exit(1 if failed else 0)
