#!/usr/bin/python3
"""Emulate a board, load a scenario case, record a run from rest, compare it
with the simulator and plot it (docs/python.md walks through the same steps).

Usage: PYTHONPATH=build/host/python python3 python/examples/record_and_plot.py [OUT.png]
Needs the qemu-m7 firmware (cmake --preset fw-qemu-m7 && cmake --build --preset fw-qemu-m7)."""
import os
import sys

import matplotlib
matplotlib.use("Agg")  # a file, no display needed
import matplotlib.pyplot as plt

import piezoloop

ROOT = os.path.abspath(os.path.join(os.path.dirname(__file__), "..", ".."))
SCENARIO = os.path.join(ROOT, "configs", "ahmad2020.json")
CASE, FREQUENCY_HZ, RANGE_UM, DURATION_S = "dahl_ff_K", 10.0, 12.0, 0.2
out_png = sys.argv[1] if len(sys.argv) > 1 else "record_and_plot.png"

with piezoloop.emulate("qemu-m7", scenario=SCENARIO) as emu, piezoloop.connect(emu.address) as dev:
    print("board:", dev.status()["hello"]["board"], "at", emu.address)
    sent = dev.set_scenario(SCENARIO, CASE, frequency_hz=FREQUENCY_HZ)
    print("sent:", ", ".join(sent["sent"]), "| clipped:", "; ".join(sent["clipped"]) or "nothing")
    rec = dev.record(DURATION_S, "r,y,e,u", trajectory="triangle", frequency_hz=FREQUENCY_HZ,
                     amplitude_um=RANGE_UM, scenario=SCENARIO, start_wave=True, restart_stage=True)
    dev.disarm()

run = piezoloop.sim(SCENARIO, CASE, frequency_hz=FREQUENCY_HZ, amplitude_um=RANGE_UM, duration_s=DURATION_S)
print(f"record: {rec.summary['frames']} frames, {rec.lost_blocks} lost blocks, "
      f"e_max {rec.summary['e_max_um']:.4f} um, hash {rec.log_hash}")
print("simulator hash:", run.log_hash, "(equal)" if run.log_hash == rec.log_hash else "(DIFFERENT)")

s = rec.signals
fig, (ax1, ax2) = plt.subplots(2, 1, sharex=True, figsize=(8, 6))
ax1.plot(s["t_s"], s["r_um"], label="r (reference)")
ax1.plot(s["t_s"], s["y_um"], label="y (board)")
ax1.set_ylabel("position (um)")
ax1.legend()
ax2.plot(s["t_s"], s["e_um"] * 1e3, label="e, board")
ax2.plot(run.signals["t_s"], run.signals["e_um"] * 1e3, "--", label="e, simulator")
ax2.set_xlabel("time (s)")
ax2.set_ylabel("error (nm)")
ax2.legend()
fig.suptitle(f"Ahmad2020 {CASE}: {RANGE_UM:g} um {FREQUENCY_HZ:g} Hz triangle on qemu-m7")
fig.savefig(out_png, dpi=100)
print("plot:", out_png)
sys.exit(0 if run.log_hash == rec.log_hash and rec.lost_blocks == 0 else 1)
