#!/usr/bin/python3
"""Case (III) of Ahmad2020 (Dahl feedforward + K(s)) on the float core and on
the Q31 core track alike: e_max within 1 % at 1, 10 and 50 Hz at the
source's 10 kHz, and at 1 Hz at 100 kHz.

The sensor noise is switched off (noise_rms = 0) for this comparison. With it
on, e_max at 1 Hz is a noise extreme (17-21 nm across five noise seeds at
100 kHz, about +-9 %): two cores that round differently by one DAC or ADC
step follow different noise paths, so their e_max differs by as much as two
seeds do. Without noise, what remains is how each core realises K(s), which
is what this test is about. The 1 % bound is the acceptance bound; the measured
spread is 0.3 % or less (docs/simulator.md).
Usage: check_float_q31_agree.py PIEZOLOOP CONFIGS_DIR"""
import json
import os
import shutil
import subprocess
import sys
import tempfile

exe, configs = sys.argv[1:3]
failed = 0
tmp = tempfile.mkdtemp(prefix="check_float_q31_")

with open(os.path.join(configs, "ahmad2020.json")) as f:
    scenario = json.load(f)
scenario["plant"]["sensor"]["noise_rms"] = 0.0
# The scenario names its models relative to itself: run it from a copy of
# configs/ in a temporary directory, never writing into the source tree.
shutil.copytree(os.path.join(configs, "models"), os.path.join(tmp, "models"))

# (rate, reference frequency): 1, 10 and 50 Hz at 10 kHz; at 100 kHz the
# 1 Hz run, where the slow pole pair matters most (and the longest run: 2 s
# of 100 kHz); `piezoloop reproduce` shows the other frequencies.
points = [(10000, 1), (10000, 10), (10000, 50), (100000, 1)]
for rate_Hz, f_Hz in points:
    scenario["loop"]["rate_Hz"] = rate_Hz
    path = os.path.join(tmp, f"ahmad2020_{rate_Hz}.json")
    with open(path, "w") as f:
        json.dump(scenario, f)
    e_max = {}
    for case in ("dahl_ff_K", "dahl_ff_K_q31"):
        r = subprocess.run([exe, "sim", "--scenario", path, "--case", case, "--trajectory", "triangle",
                            "--frequency-hz", str(f_Hz), "--amplitude-um", "12"],
                           capture_output=True, text=True)
        if r.returncode != 0:
            print(f"FAIL {case} at {rate_Hz} Hz rate, {f_Hz} Hz: {r.stderr}")
            failed += 1
            continue
        e_max[case] = json.loads(r.stdout)["e_max_um"]
    if len(e_max) == 2:
        a, b = e_max["dahl_ff_K"], e_max["dahl_ff_K_q31"]
        rel = abs(a - b) / a
        ok = rel <= 0.01
        print(f"{'ok' if ok else 'FAIL'} rate {rate_Hz} Hz, {f_Hz} Hz triangle: e_max float {a:.6g} um, "
              f"Q31 {b:.6g} um, {100 * rel:.3f} % apart")
        failed += 0 if ok else 1
sys.exit(1 if failed else 0)
