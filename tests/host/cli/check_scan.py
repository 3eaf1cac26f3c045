#!/usr/bin/python3
"""`piezoloop scan` on configs/stages/xy_flexure.json: a 64 x 64 raster and a
spiral at 50 lines (turns) a second, far below the stage's first mode
(750 Hz), in closed loop (the case pi_notch). Checks the files, every figure of metrics.json against a
recomputation from scan.csv (pixels formed here anew: numpy), the grating's
pitch at measured positions within 1 % of the sample's and, for the raster,
at commanded positions the pitch its tracking error predicts, the refusals (exit 2
naming the option, nothing written) and Ctrl-C (exit 4, what arrived
written and marked incomplete).
Usage: check_scan.py PIEZOLOOP_BINARY CONFIGS_DIR"""
import json
import os
import signal
import subprocess
import sys
import tempfile
import time

import numpy as np

exe, configs = sys.argv[1], sys.argv[2]
scenario = os.path.join(configs, "stages", "xy_flexure.json")
passed = failed = 0


def check(name, ok, detail=""):
    global passed, failed
    if ok:
        passed += 1
    else:
        failed += 1
        print(f"FAIL {name} {detail}")


def close(a, b, rel=1e-5, abs_=1e-6):
    """CSV values carry 9 significant digits (positions near 50 um: 1e-7 um)."""
    return abs(a - b) <= abs_ + rel * abs(b)


def recompute(csv, rate, raster):
    d = np.genfromtxt(csv, delimiter=",", names=True)
    sync = d["sync"].astype(np.int64)
    n = len(sync)
    clocks = np.flatnonzero(sync & 4)
    gaps = np.diff(clocks)
    values, counts = np.unique(gaps, return_counts=True)
    usual = int(values[np.argmax(counts)])  # the most frequent; ties: the shorter
    nxt = np.append(clocks[1:], n)
    length = np.minimum(nxt - clocks, usual)
    used = np.zeros(n, bool)
    for k, m in zip(clocks, length):
        used[k:k + m] = True
    ex = (d["commanded_x_um"] - d["measured_x_um"])[used]
    ey = (d["commanded_y_um"] - d["measured_y_um"])[used]
    out = {"ticks": n, "used_ticks": int(used.sum()), "pixels": len(clocks), "used": used,
           "rms_x_um": float(np.sqrt(np.mean(ex ** 2))), "max_x_um": float(np.max(np.abs(ex))),
           "rms_y_um": float(np.sqrt(np.mean(ey ** 2))), "max_y_um": float(np.max(np.abs(ey)))}
    starts = np.flatnonzero(sync & 2)
    out["lines"] = len(starts)
    out["used_fraction"] = float(np.mean([used[a:b].mean() for a, b in zip(starts[:-1], starts[1:])]))
    frames = np.flatnonzero(sync & 1)
    out["frame_time_s"] = ((frames[1] if len(frames) > 1 else n) - frames[0]) / rate
    last = used.copy()
    last[:frames[-1]] = False
    lx = (d["commanded_x_um"] - d["measured_x_um"])[last]
    ly = (d["commanded_y_um"] - d["measured_y_um"])[last]
    out["last_frame"] = len(frames) - 1
    out["last"] = {"rms_x_um": float(np.sqrt(np.mean(lx ** 2))), "max_x_um": float(np.max(np.abs(lx))),
                   "rms_y_um": float(np.sqrt(np.mean(ly ** 2))), "max_y_um": float(np.max(np.abs(ly)))}
    if raster:
        # Pixel clocks grouped by (frame, line) as the clocks count them.
        frame = np.cumsum(sync & 1 > 0)
        line_start = np.cumsum(sync & 2 > 0)
        key = frame * 100000 + line_start
        worst = 0.0
        for kk in np.unique(key[clocks]):
            x = d["measured_x_um"][clocks[key[clocks] == kk]]
            if len(x) >= 3:
                i = np.arange(len(x))
                fit = np.polyval(np.polyfit(i, x, 1), i)
                worst = max(worst, float(np.max(np.abs(x - fit))))
        out["linearity_um"] = worst
    return out


def run(args, out):
    return subprocess.run([exe, "scan", "--scenario", scenario, "--out", out] + args, capture_output=True, text=True)


with tempfile.TemporaryDirectory() as tmp:
    for pattern in ("raster", "spiral"):
        out = os.path.join(tmp, pattern)
        res = run(["--case", "pi_notch", "--pattern", pattern, "--size-um", "20x20", "--pixels", "64x64", "--line-rate-hz", "50",
                   "--sample", "grating:pitch=2,height_nm=50"], out)
        check(f"{pattern}: exit 0", res.returncode == 0, res.stderr)
        if res.returncode != 0:
            continue
        for f in ("scan.csv", "metrics.json", "image_commanded.png", "image_measured.png", "error_x.png",
                  "error_y.png"):
            path = os.path.join(out, f)
            ok = os.path.isfile(path) and os.path.getsize(path) > 0
            if ok and f.endswith(".png"):
                with open(path, "rb") as fh:
                    ok = fh.read(8) == b"\x89PNG\r\n\x1a\n"
            check(f"{pattern}: {f} written", ok)
        with open(os.path.join(out, "metrics.json")) as fh:
            m = json.load(fh)
        check(f"{pattern}: stdout is metrics.json", json.loads(res.stdout) == m)
        check(f"{pattern}: complete", m["complete"] is True and m["frames_completed"] == 1)
        check(f"{pattern}: the case", m["case"] == "pi_notch" and m["sample_type"] == "float")
        r = recompute(os.path.join(out, "scan.csv"), m["rate_Hz"], pattern == "raster")
        for k in ("ticks", "used_ticks", "pixels", "lines"):
            check(f"{pattern}: {k} recomputed", r[k] == m[k], f"{r[k]} vs {m[k]}")
        for k in ("rms_x_um", "max_x_um", "rms_y_um", "max_y_um"):
            check(f"{pattern}: tracking.{k} recomputed", close(r[k], m["tracking"][k]), f"{r[k]} vs {m['tracking'][k]}")
            pct = 100 * m["tracking"][k] / m["size_um"][0 if "_x_" in k else 1]
            check(f"{pattern}: tracking {k} in %", close(pct, m["tracking"][k.replace("_um", "_percent")]))
            check(f"{pattern}: tracking_last_frame.{k} recomputed", close(r["last"][k], m["tracking_last_frame"][k]),
                  f"{r['last'][k]} vs {m['tracking_last_frame'][k]}")
        check(f"{pattern}: last_frame recomputed", r["last_frame"] == m["last_frame"])
        for k in ("used_fraction", "frame_time_s") + (("linearity_um",) if pattern == "raster" else ()):
            check(f"{pattern}: {k} recomputed", close(r[k], m[k]), f"{r[k]} vs {m[k]}")
        check(f"{pattern}: pixels expected", m["pixels"] == (64 * 64 if pattern == "raster" else 32 * 200),
              m["pixels"])
        err = abs(m["pitch"]["measured_um"] / 2.0 - 1.0)
        check(f"{pattern}: pitch at measured positions within 1 %", err < 0.01, m["pitch"])
        if pattern == "raster":
            # At commanded positions the distortion the tracking error
            # predicts: measured x ~ a * commanded x + b over the used ticks
            # (least squares) puts a grating of pitch p at commanded
            # positions p / a apart (0.03 % here; 1 % allowed).
            d = np.genfromtxt(os.path.join(out, "scan.csv"), delimiter=",", names=True)
            used = r["used"]
            a = np.polyfit(d["commanded_x_um"][used], d["measured_x_um"][used], 1)[0]
            predicted = m["pitch"]["measured_um"] / a
            check("raster: pitch at commanded positions as the tracking error predicts",
                  abs(m["pitch"]["commanded_um"] / predicted - 1.0) < 0.01, (m["pitch"]["commanded_um"], predicted, a))
        print(f"{pattern}: rms x {m['tracking']['rms_x_percent']:.2f} %, max x {m['tracking']['max_x_percent']:.2f} %,"
              f" pitch measured {m['pitch']['measured_um']:.4f} um, commanded {m['pitch']['commanded_um']:.4f} um")

    # The same case in Q31 (the core's fixed-point pipeline and scan feed):
    # the same figures within a few percent, the pitch at measured positions
    # within 1 %.
    with open(scenario) as fh:
        q = json.load(fh)
    for c in q["cases"]:
        if c["name"] == "pi_notch":
            c["sample"] = "q31"
    q31_scenario = os.path.join(tmp, "xy_flexure_q31.json")
    with open(q31_scenario, "w") as fh:
        json.dump(q, fh)
    out = os.path.join(tmp, "q31")
    res = subprocess.run([exe, "scan", "--scenario", q31_scenario, "--case", "pi_notch", "--pixels", "64x64",
                          "--out", out], capture_output=True, text=True)
    check("q31: exit 0", res.returncode == 0, res.stderr)
    if res.returncode == 0:
        mq = json.loads(res.stdout)
        with open(os.path.join(tmp, "raster", "metrics.json")) as fh:
            mf = json.load(fh)
        check("q31: sample type", mq["sample_type"] == "q31")
        check("q31: pitch at measured positions within 1 %", abs(mq["pitch"]["measured_um"] / 2.0 - 1.0) < 0.01,
              mq["pitch"])
        # Q31 rounding (2^-31 of 128 um, and the controllers' fixed point)
        # against float: the tracking error within 2 % of itself.
        check("q31: rms x as float's", close(mq["tracking"]["rms_x_um"], mf["tracking"]["rms_x_um"], rel=0.02),
              f"{mq['tracking']['rms_x_um']} vs {mf['tracking']['rms_x_um']}")
        check("q31: same ticks", mq["ticks"] == mf["ticks"] and mq["pixels"] == mf["pixels"])

    # Refusals: exit 2, the option named, nothing written.
    refusals = [
        (["--pixels", "64"], "--pixels"),
        (["--pixels", "1x64"], "--pixels"),
        (["--pixels", "4096x64"], "--pixels"),  # more pixels than ticks in a line's used part
        (["--size-um", "0x20"], "--size-um"),
        (["--size-um", "200x200"], "--size-um"),  # beyond the axes' travel
        (["--centre-um", "5,50"], "--centre-um"),
        (["--line-rate-hz", "6000"], "--line-rate-hz"),
        (["--pixels", "8x8", "--line-rate-hz", "4000"], "--line-rate-hz"),  # turnarounds under 2 ticks: the core's refusal
        (["--frames", "0"], "--frames"),
        (["--pixels", "256x256", "--line-rate-hz", "1", "--frames", "1000"], "--frames"),  # 5.1e9 ticks, memory
        (["--retrace-speed", "0.5"], "--retrace-speed"),
        (["--pattern", "spiral", "--retrace-speed", "2"], "--retrace-speed"),
        (["--case", "nope"], "--case"),
        (["--sample-type", "double"], "--sample-type"),
        (["--restart-stage"], "--restart-stage"),  # a board's options, on the simulator
        (["--rc-period-from-scan"], "--rc-period-from-scan"),
        (["--pattern", "zigzag"], "--pattern"),
        (["--sample", "ruler:pitch=2"], "--sample"),
        (["--sample", "grating:pitch=-1"], "--sample"),
    ]
    for args, option in refusals:
        out = os.path.join(tmp, "refused")
        res = run(args if args[0] == "--pixels" else ["--pixels", "64x64"] + args, out)
        check(f"refused {args}", res.returncode == 2 and option in res.stderr and not os.path.exists(out),
              f"exit {res.returncode}: {res.stderr.strip()}")
    single = subprocess.run([exe, "scan", "--scenario", os.path.join(configs, "ahmad2020.json"), "--out",
                             os.path.join(tmp, "single")], capture_output=True, text=True)
    check("single-axis scenario refused", single.returncode == 2 and "--scenario" in single.stderr,
          f"exit {single.returncode}: {single.stderr.strip()}")

    # Ctrl-C: what arrived is written and marked incomplete. The scan would
    # take 10 frames of 64 s of stage time (minutes here); it is stopped
    # after 0.2 s (a few 1e5 ticks).
    out = os.path.join(tmp, "stopped")
    p = subprocess.Popen([exe, "scan", "--scenario", scenario, "--out", out, "--pixels", "64x64", "--line-rate-hz",
                          "1", "--frames", "10"], stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
    time.sleep(0.2)
    check("Ctrl-C: still running when signalled", p.poll() is None)
    p.send_signal(signal.SIGINT)
    _, err = p.communicate(timeout=60)
    check("Ctrl-C: exit 4", p.returncode == 4, f"exit {p.returncode}: {err.strip()}")
    try:
        with open(os.path.join(out, "metrics.json")) as fh:
            m = json.load(fh)
        check("Ctrl-C: marked incomplete", m["complete"] is False and m["frames_completed"] < 100)
        check("Ctrl-C: ticks written", m["ticks"] > 0 and os.path.getsize(os.path.join(out, "scan.csv")) > 0)
    except OSError as e:
        check("Ctrl-C: metrics written", False, str(e))

print(f"{passed} passed, {failed} failed")
sys.exit(1 if failed else 0)
