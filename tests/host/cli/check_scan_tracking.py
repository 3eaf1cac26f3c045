#!/usr/bin/python3
"""Tracking of `piezoloop scan` on configs/stages/xy_flexure.json, 20 x 20 um:
a 256-line raster at a tenth of the first mode (75 Hz lines, 96 x 256: 96
pixels a line round the line rate nearest 75 Hz, 75.19 Hz), a spiral at a third of
it (250 turns a second, 64 x 64: 32 turns) and a Lissajous scan whose x runs
at a third of it (f_x 250 Hz: 500 lines a second, 20 x 16, y's period
rounded to 85 ticks; six frames of 1360 ticks), for the cases open_loop,
pi_notch, scan (PI inverse feedforward) and scan_rc (the inverse in series,
plus repetitive control at each axis's period). The Lissajous run's
repetitive controllers learn over its first frames; its last frame
(metrics.json tracking_last_frame, checked against scan.csv: every tick of a
Lissajous frame is inside a pixel) is judged too. The simulator is deterministic (seeded sensor noise),
so the bounds are the measured figures plus a few percent of themselves
(compiler and libm differences), and they fail if the feedforward or the RC
is removed (the orderings). Prints every figure (docs/scan.md's table).
Usage: check_scan_tracking.py PIEZOLOOP_BINARY CONFIGS_DIR"""
import json
import os
import subprocess
import sys
import tempfile

exe, configs = sys.argv[1], sys.argv[2]
scenario = os.path.join(configs, "stages", "xy_flexure.json")
passed = failed = 0


def small_gain_peak(axis, case, period_ticks):
    """sup over 0 < w <= pi of |Q| |1 - k_rc z^m2 T| for the case's axis with
    the PI inverse in series (the loop sees the linearised stage), built with
    scipy: the amplifier's and sensor's lags and the dynamics (unit DC gain)
    sampled with a zero-order hold, the controller by Tustin pre-warped as
    the scenario says, Q Shan2012's 0.3558 / (z - 0.6442). Independent of
    the tool's assembly of the loop (sim/rc_check.cpp); the period does not
    enter this condition."""
    import numpy as np
    from scipy import signal
    with open(scenario) as f:
        sc = json.load(f)
    rate = sc["loop"]["rate_Hz"]
    plant = sc["plant"]["axes"][axis]
    cplx = lambda v: [complex(a, b) for a, b in v]
    poles = cplx(plant["dynamics"]["model"]["poles"])
    zeros = cplx(plant["dynamics"]["model"]["zeros"])
    k = (np.prod([-p for p in poles]) / np.prod([-z for z in zeros])).real
    for f_Hz in (plant["amplifier"]["bandwidth_Hz"], plant["sensor"]["bandwidth_Hz"]):
        poles.append(-2 * np.pi * f_Hz)
        k *= 2 * np.pi * f_Hz
    num, den = signal.zpk2tf(zeros, poles, k)
    bg, ag, _ = signal.cont2discrete((num, den), 1 / rate, method="zoh")
    fb = [c for c in sc["cases"] if c["name"] == case][0]["controller"]["axes"]["xy"[axis]]
    rc = fb["rc"]
    fb = fb["feedback"]
    w0 = 2 * np.pi * fb["prewarp_Hz"]
    zk, pk, kk = signal.bilinear_zpk(cplx(fb["model"]["zeros"]), cplx(fb["model"]["poles"]), fb["model"]["gain"],
                                     fs=w0 / (2 * np.tan(w0 / (2 * rate))))
    bk, ak = signal.zpk2tf(zk, pk, kk)
    w = np.linspace(1e-5, np.pi, 400001)
    z = np.exp(1j * w)
    L = np.polyval(np.ravel(bg), z) / np.polyval(ag, z) * np.polyval(bk, z) / np.polyval(ak, z)
    T = L / (1 + L)
    Q = 0.3558 / (z - 0.6442)
    g = np.abs(Q) * np.abs(1 - rc["k_rc"] * z ** rc["m2"] * T)
    i = int(np.argmax(g))
    return float(g[i]), float(w[i] * rate / (2 * np.pi))


def check(name, ok, detail=""):
    global passed, failed
    if ok:
        passed += 1
    else:
        failed += 1
        print(f"FAIL {name} {detail}")


runs = {"raster": ["--pixels", "96x256", "--line-rate-hz", "75"], "spiral": ["--pixels", "64x64", "--line-rate-hz", "250"],
        "lissajous": ["--pixels", "20x16", "--line-rate-hz", "500", "--frames", "6"]}
fig = {}
last_frames = {}  # (pattern, case) -> (x, y): RMS % over the last frame
with tempfile.TemporaryDirectory() as tmp:
    for pattern, args in runs.items():
        for case in ("open_loop", "pi_notch", "scan", "scan_rc"):
            out = os.path.join(tmp, f"{pattern}_{case}")
            res = subprocess.run([exe, "scan", "--scenario", scenario, "--case", case, "--pattern", pattern,
                                  "--size-um", "20x20", "--out", out] + args, capture_output=True, text=True)
            check(f"{pattern} {case}: exit 0", res.returncode == 0, res.stderr)
            if res.returncode != 0:
                continue
            m = json.loads(res.stdout)
            check(f"{pattern} {case}: complete", m["complete"] is True)
            t = m["tracking"]
            fig[pattern, case] = t
            print(f"{pattern:9} {case:9} line rate {m['line_rate_Hz']:.2f} Hz: x {t['rms_x_percent']:.2f} / "
                  f"{t['max_x_percent']:.2f} %, y {t['rms_y_percent']:.2f} / {t['max_y_percent']:.2f} % (RMS / max), "
                  f"pitch measured {m['pitch']['measured_um'] or float('nan'):.4f} um")
            if case == "scan_rc":
                # Each axis's RC: stable on its linearised loop (the small-gain
                # condition and the exact roots), the peak as scipy computes it
                # (3e-10 apart here; 1e-6 allows for its 400 001-point grid).
                rcs = m.get("rc_stability", {})
                # The periods "auto" sets: a raster's line (266 ticks at
                # 75.19 Hz), a spiral's turn (80), each Lissajous axis's own
                # sinusoid (80 and 85).
                periods = {"raster": (266, 266), "spiral": (80, 80), "lissajous": (80, 85)}[pattern]
                check(f"{pattern} scan_rc: each axis's RC period", tuple(rcs.get(n, {}).get("period_ticks") for n in "xy")
                      == periods, rcs)
                for a, name in ((0, "x"), (1, "y")):
                    r = rcs.get(name)
                    check(f"{pattern} scan_rc: {name}'s RC analysed", r is not None, rcs)
                    if r is None:
                        continue
                    check(f"{pattern} scan_rc: {name}'s RC stable on its linearised loop",
                          r["loop_stable"] and r["small_gain_ok"] and r["stable"] is True, r)
                    peak, at_Hz = small_gain_peak(a, "scan_rc", r["period_ticks"])
                    check(f"{pattern} scan_rc: {name}'s small-gain peak as scipy's",
                          abs(r["small_gain_peak"] - peak) <= 1e-6 * peak, (r["small_gain_peak"], peak, at_Hz))
                    print(f"{'':9} scan_rc   {name}'s RC over {r['period_ticks']} ticks: small-gain peak "
                          f"{r['small_gain_peak']:.4f} at {r['small_gain_at_Hz']:.0f} Hz (scipy {peak:.4f} at "
                          f"{at_Hz:.0f} Hz), largest root {r['max_abs_root']:.6f}")
            if pattern == "lissajous":
                with open(os.path.join(out, "scan.csv")) as f:
                    rows = [line.split(",") for line in f.read().splitlines()[1:]]
                n = round(m["frame_time_s"] * m["rate_Hz"])
                check("lissajous: six frames recorded", len(rows) == 6 * n and m["last_frame"] == 5, len(rows))
                rms = [(sum((float(r[1 + a]) - float(r[3 + a])) ** 2 for r in rows[-n:]) / n) ** 0.5 / 20.0 * 100.0
                       for a in (0, 1)]
                t = m["tracking_last_frame"]
                check(f"lissajous {case}: tracking_last_frame as scan.csv's last frame",
                      all(abs(t[f"rms_{x}_percent"] - v) <= 1e-4 * v for x, v in zip("xy", rms)), (t, rms))
                last_frames[pattern, case] = (t["rms_x_percent"], t["rms_y_percent"])
                print(f"{'':9} {case:9} last frame: x {t['rms_x_percent']:.2f} %, y {t['rms_y_percent']:.2f} % (RMS)")

if len(fig) == 12:
    rx = lambda p, c: fig[p, c]["rms_x_percent"]
    ry = lambda p, c: fig[p, c]["rms_y_percent"]
    # The 1 % target (RMS over the used part of the lines), where met: the
    # raster's x and y with scan_rc, its y with scan, the spiral's x and y
    # with scan_rc, the Lissajous scan's once its RC has learnt.
    check("raster scan_rc: rms x within 1 %", rx("raster", "scan_rc") <= 1.0, rx("raster", "scan_rc"))
    check("raster scan_rc: rms y within 1 %", ry("raster", "scan_rc") <= 1.0, ry("raster", "scan_rc"))
    check("raster scan: rms y within 1 %", ry("raster", "scan") <= 1.0, ry("raster", "scan"))
    check("spiral scan_rc: rms x within 1 %", rx("spiral", "scan_rc") <= 1.0, rx("spiral", "scan_rc"))
    check("spiral scan_rc: rms y within 1 %", ry("spiral", "scan_rc") <= 1.0, ry("spiral", "scan_rc"))
    lx, ly = last_frames["lissajous", "scan_rc"]
    check("lissajous scan_rc, last frame: rms x within 1 %", lx <= 1.0, lx)
    check("lissajous scan_rc, last frame: rms y within 1 %", ly <= 1.0, ly)
    # The raster's x without RC is not met (docs/scan.md). Every figure is
    # held at today's (+ ~8 %) so that none regresses.
    bounds = {("raster", "scan_rc"): (0.56, 0.13), ("raster", "scan"): (1.17, 0.27),
              ("spiral", "scan_rc"): (0.64, 0.70), ("spiral", "scan"): (7.15, 5.33),
              ("lissajous", "scan_rc"): (2.93, 1.28), ("lissajous", "scan"): (11.3, 8.30)}
    for (p, c), (bx, by) in bounds.items():
        check(f"{p} {c}: rms x <= {bx} %", rx(p, c) <= bx, rx(p, c))
        check(f"{p} {c}: rms y <= {by} %", ry(p, c) <= by, ry(p, c))
    # The feedforward and the RC each earn their place: removing either
    # makes x worse by more than the margins above.
    check("raster: feedforward beats pi_notch on x by 4x", rx("raster", "scan") * 4 < rx("raster", "pi_notch"))
    check("raster: RC beats scan on x by 20 %", rx("raster", "scan_rc") * 1.2 < rx("raster", "scan"))
    check("raster: RC beats scan on y", ry("raster", "scan_rc") < ry("raster", "scan"))
    check("spiral: RC beats scan on x by 2x", rx("spiral", "scan_rc") * 2 < rx("spiral", "scan"))
    check("spiral: RC beats scan on y by 2x", ry("spiral", "scan_rc") * 2 < ry("spiral", "scan"))
    check("spiral: scan_rc beats open loop and pi_notch",
          rx("spiral", "scan_rc") < min(rx("spiral", "open_loop"), rx("spiral", "pi_notch")))
    check("lissajous: RC beats scan on x by 3x", rx("lissajous", "scan_rc") * 3 < rx("lissajous", "scan"))
    check("lissajous: RC beats scan on y by 3x", ry("lissajous", "scan_rc") * 3 < ry("lissajous", "scan"))
    for a, name in ((0, "x"), (1, "y")):
        check(f"lissajous: scan_rc's last frames beat its whole run on {name}",
              last_frames["lissajous", "scan_rc"][a] < fig["lissajous", "scan_rc"][f"rms_{name}_percent"])

print(f"{passed} passed, {failed} failed")
sys.exit(1 if failed else 0)
