#!/usr/bin/python3
"""Commissioning on every shipped stage: the ten-stage sweep of
docs/commissioning.md as a benchmark (minutes, so not a ctest).

For each stage (configs/*.json and configs/stages/*.json, each at the range
docs/commissioning.md gives it) runs `piezoloop commission --scenario` (the
simulator) and, with --board, the same on an emulated qemu-m7 board
(`piezoloop emulate`, the limits group set first to the stage's command
range within the board's +-10 V and 2e5 V/s, as the docs ask). Prints one
table: the chosen controller, e_max of the check (10 Hz over half the range)
and of the 1 Hz triangle over the whole range, each with its prediction,
the measured closed-loop bandwidth, 5 / bandwidth (the recovery bound of
docs/commissioning.md) and the wall time. Nothing is asserted.

Usage: tools/bench_commission.py [--piezoloop EXE] [--board] [--image ELF]
                                 [--only NAME ...] [--out DIR] [--json FILE]
"""
import argparse
import json
import os
import subprocess
import sys
import tempfile
import time

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))

# (stage, scenario file, range in um): the ranges of docs/commissioning.md.
STAGES = [
    ("stiff_stack", "configs/stages/stiff_stack.json", 12),
    ("soft_bender", "configs/stages/soft_bender.json", 24),
    ("rhp_zero", "configs/stages/rhp_zero.json", 20),
    ("stiff_stack_unipolar", "configs/stages/stiff_stack_unipolar.json", 12),
    ("drifting_stage", "configs/stages/drifting_stage.json", 20),
    ("strong_hysteresis", "configs/stages/strong_hysteresis.json", 28),
    ("asymmetric_hysteresis", "configs/stages/asymmetric_hysteresis.json", 16),
    ("ahmad2020", "configs/ahmad2020.json", 12),
    ("shan2012", "configs/shan2012.json", 8),
    ("janaideh2016", "configs/janaideh2016.json", 20),
]

BOARD_V = 10.0            # the emulated board's command span is +-10 V
BOARD_SLEW = 2e5          # and its slew limit, V/s


def board_limits(scenario):
    """The stage's command range (its hard limits) within the board's."""
    h = json.load(open(scenario))["loop"]["hard_limits"]
    return {"u_min_V": max(h["u_min_V"], -BOARD_V), "u_max_V": min(h["u_max_V"], BOARD_V),
            "slew_V_per_s": min(h["slew_V_per_s"], BOARD_SLEW)}


def start_board(exe, scenario, image):
    args = [exe, "emulate", "--board", "qemu-m7", "--scenario", scenario]
    if image:
        args += ["--image", image]
    emu = subprocess.Popen(args, stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
    info = json.loads(emu.stdout.readline())
    return emu, ["--device", info["device"]]


def stop_board(emu):
    if emu.poll() is None:
        emu.terminate()
        try:
            emu.wait(timeout=20)
        except subprocess.TimeoutExpired:
            emu.kill()
            emu.wait()


def commission(exe, where, scenario, range_um, out):
    """One commissioning; returns its summary JSON (or the failure)."""
    args = [exe, *where, "commission"]
    if not where:
        args += ["--scenario", scenario]
    args += ["--range-um", str(range_um), "--out", out]
    if where:
        args += ["--no-save"]
    t0 = time.monotonic()
    r = subprocess.run(args, capture_output=True, text=True, timeout=600)
    try:
        j = json.loads(r.stdout)
    except json.JSONDecodeError:
        j = {}
    j["exit"] = r.returncode
    j.setdefault("wall_s", time.monotonic() - t0)
    if r.returncode != 0:
        j["error"] = r.stderr.strip().splitlines()[-1] if r.stderr.strip() else "exit %d" % r.returncode
    return j


def row(name, rng, j):
    v = j.get("verification") or []
    def run(i):
        if len(v) <= i:
            return "-"
        m, p = v[i].get("measured", {}), v[i].get("predicted", {})
        return "%.2f %% (%.2f)" % (m.get("e_max_pct", float("nan")), p.get("e_max_pct", float("nan")))
    bw = j.get("bandwidth_Hz") or 0.0
    bound = "%.1f ms" % (5e3 / bw) if bw > 0 else "-"
    status = "verified" if j.get("verified") else j.get("error", "not verified")
    return "| %s, %g um | %s | %s | %s | %.0f Hz | %s | %.1f s | %s |" % (
        name, rng, j.get("chosen") or "-", run(0), run(1), bw, bound, j.get("wall_s", 0.0), status)


def main():
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--piezoloop", default=os.path.join(ROOT, "build/host/host/piezoloop"))
    ap.add_argument("--board", action="store_true", help="also on an emulated qemu-m7 board")
    ap.add_argument("--image", default="", help="the qemu-m7 servo.elf (default: emulate's own)")
    ap.add_argument("--only", nargs="*", default=[], help="stage names to run (default: all ten)")
    ap.add_argument("--out", default="", help="where each run's files go (default: a temporary folder)")
    ap.add_argument("--json", default="", help="write every summary here")
    a = ap.parse_args()
    out = a.out or tempfile.mkdtemp(prefix="bench_commission_")
    stages = [s for s in STAGES if not a.only or s[0] in a.only]
    results = {}
    for where_name in ["simulator"] + (["qemu-m7"] if a.board else []):
        print("\n%s\n" % where_name)
        print("| stage, range | chosen | 10 Hz, half range (predicted) | 1 Hz, whole range (predicted) "
              "| bandwidth | 5 / bandwidth | wall | |")
        print("|---|---|---|---|---|---|---|---|")
        for name, cfg, rng in stages:
            scenario = os.path.join(ROOT, cfg)
            run_out = os.path.join(out, where_name, name)
            if where_name == "simulator":
                j = commission(a.piezoloop, [], scenario, rng, run_out)
            else:
                emu, dev = start_board(a.piezoloop, scenario, a.image)
                try:
                    lim = subprocess.run([a.piezoloop, *dev, "set", "limits", "--json",
                                          json.dumps(board_limits(scenario))], capture_output=True, text=True)
                    if lim.returncode != 0:
                        sys.exit("set limits on %s: %s" % (name, lim.stderr))
                    j = commission(a.piezoloop, dev, scenario, rng, run_out)
                finally:
                    stop_board(emu)
            results.setdefault(where_name, {})[name] = j
            print(row(name, rng, j), flush=True)
    if a.json:
        json.dump(results, open(a.json, "w"), indent=1)


if __name__ == "__main__":
    main()
