#!/usr/bin/python3
"""End-to-end checks of `piezoloop measure frf` (simulator) and `piezoloop
identify tf` (docs/measurement.md).

1. Open-loop multisine on the Ahmad2020 stage with its sensor noise on (and
   its 16-bit converters), with the float core and with the Q31 core: the
   measured response u (V) -> y (um) is within
   0.5 dB and 3 deg of the stage's exact sampled response on every line from
   10 Hz to 0.4 x the loop rate whose standard deviation is <= 0.1 dB (SNR
   >= 39 dB; at least half of the 400 lines). The exact response is computed
   here from the scenario's model with scipy: the dynamics (models/
   ahmad2020_G.json, normalised to unit DC gain) discretised by ZOH at the
   loop rate -- its one sample of delay is the loop's tick of compute delay:
   the command computed at tick k is held over [k, k+1) and read back at tick
   k + 1 (common/piezoloop/loop_stepper.hpp) -- times the amplifier's gain
   (10) and the hysteresis' local slope. The stage's PI hysteresis has its
   first play operator at 1 V of piezo voltage; an excitation of 0.09 V peak
   (0.9 V on the piezo, 1.8 V peak-to-peak, below the operator's 2 V band)
   leaves every operator still after the first (discarded) period, so the
   slope is exactly p0 = 0.1159 um/V at any bias.
2. identify tf on that response: 6 poles, 5 zeros and one sample of delay
   (the ZOH structure: b0 = 0): the resonances of the model (1004.8 Hz, zeta 0.104; 2226.8 Hz,
   zeta 0.121) within 2 % in frequency and 20 % in damping; orders the data
   cannot support are refused with the reason.
1b. The same with a logarithmic swept sine and a PRBS (H1 with Welch
   averaging): within 0.5 dB and 3 deg wherever the coherence is >= 0.95.
3. Hostile requests are refused with exit 2, the option named, nothing
   written.
Usage: check_measure.py PIEZOLOOP_BINARY CONFIGS_DIR"""
import json
import math
import os
import subprocess
import sys
import tempfile

import numpy as np
from scipy import signal

exe, configs = sys.argv[1], sys.argv[2]
tmp = tempfile.mkdtemp(prefix="piezoloop_measure_")
scenario = os.path.join(configs, "ahmad2020.json")
failed = 0


def check(name, ok, detail=""):
    global failed
    print(("ok   " if ok else "FAIL ") + name + (f": {detail}" if detail else ""))
    if not ok:
        failed += 1


def run(*args):
    return subprocess.run([exe, *args], capture_output=True, text=True)


def accuracy(path, core):
    """The measured response in `path` against the exact sampled one."""
    j = json.load(open(path))
    for key in ("frequency_Hz", "response", "std_db", "input", "output", "units", "clipped_samples", "warnings"):
        check(f"{core}: frf.json has {key}", key in j)
    f = np.array(j["frequency_Hz"])
    g = np.array([complex(a, b) for a, b in j["response"]])
    sd = np.array([math.nan if x is None else x for x in j["std_db"]])
    check(f"{core}: lines 10 Hz .. 4 kHz", len(f) == 400 and f[0] == 10.0 and f[-1] == 4000.0,
          f"{len(f)} {f[0]} {f[-1]}")
    check(f"{core}: nothing clipped", j["clipped_samples"] == 0, str(j["clipped_samples"]))
    model = json.load(open(os.path.join(configs, "models", "ahmad2020_G.json")))
    num = np.array(model["num"]) / model["num"][-1] * model["den"][-1]  # unit DC gain
    den = np.array(model["den"])
    fs = 10000.0
    bd, ad, _ = signal.cont2discrete((num, den), 1.0 / fs, method="zoh")
    z = np.exp(2j * np.pi * f / fs)
    exact = 10.0 * 0.1159 * np.polyval(bd.ravel(), z) / np.polyval(ad, z)
    ratio = g / exact
    high = sd <= 0.1
    err_db = np.abs(20 * np.log10(np.abs(ratio[high])))
    err_deg = np.abs(np.angle(ratio[high], deg=True))
    print(f"     {core}: {high.sum()} of {len(f)} lines with std <= 0.1 dB (up to {f[high].max():.0f} Hz): "
          f"max error {err_db.max():.3f} dB, {err_deg.max():.3f} deg")
    check(f"{core}: most lines have a high SNR", high.sum() >= 200, str(high.sum()))
    check(f"{core}: within 0.5 dB of the exact response", err_db.max() <= 0.5, f"{err_db.max():.3f} dB")
    check(f"{core}: within 3 deg of the exact response", err_deg.max() <= 3.0, f"{err_deg.max():.3f} deg")
    # The noise estimate is honest: the errors over the high-SNR lines are
    # about one standard deviation (|G| in dB), not many.
    z_scores = 20 * np.log10(np.abs(ratio[high])) / sd[high]
    check(f"{core}: errors consistent with std_db", 0.5 < np.std(z_scores) < 1.6, f"{np.std(z_scores):.2f}")


# 1. The response against the exact one, with the float core and with the
# Q31 core (the emulated boards' recordings equal these: check_measure_e2e.py).
frf = os.path.join(tmp, "frf.json")
frf_q31 = os.path.join(tmp, "frf_q31.json")
res_q31 = run("measure", "frf", "--scenario", scenario, "--sample", "q31", "--from-hz", "10", "--to-hz", "4000",
              "--amplitude-v", "0.09", "--bias-v", "3", "--periods", "40", "--out", frf_q31)
check("measure frf --sample q31 runs", res_q31.returncode == 0, res_q31.stderr)
res = run("measure", "frf", "--scenario", scenario, "--from-hz", "10", "--to-hz", "4000", "--amplitude-v", "0.09",
          "--bias-v", "3", "--periods", "40", "--out", frf)
check("measure frf runs", res.returncode == 0, res.stderr)
for path, core in ((frf, "float"), (frf_q31, "q31")):
    if os.path.exists(path):
        accuracy(path, core)
if res.returncode == 0:
    print("     " + res.stderr.strip())
    # 2. identify tf.
    model_out = os.path.join(tmp, "fit.json")
    res = run("identify", "tf", "--frf", frf, "--order", "6/5", "--delay-samples", "1", "--out", model_out)
    check("identify tf runs", res.returncode == 0, res.stderr)
    if res.returncode == 0:
        fit = json.loads(res.stdout)
        truth = [(1004.75, 0.10389), (2226.81, 0.12101), (815.82, 0.59519)]
        for f0, z0 in truth:
            best = min(fit["resonances"], key=lambda r: abs(r["frequency_Hz"] - f0))
            df = abs(best["frequency_Hz"] / f0 - 1)
            dz = abs(best["damping"] / z0 - 1)
            print(f"     resonance {f0} Hz: fitted {best['frequency_Hz']:.2f} Hz ({100 * df:.3f} %), "
                  f"zeta {best['damping']:.4f} ({100 * dz:.2f} %)")
            check(f"resonance {f0} Hz within 2 %", df <= 0.02, f"{100 * df:.2f} %")
            check(f"damping at {f0} Hz within 20 %", dz <= 0.2, f"{100 * dz:.2f} %")
        m = json.load(open(model_out))
        check("model file in the configs/models format", set(m) >= {"num", "den", "ts", "name"}, str(sorted(m)))
        check("fit error per decade", len(fit["fit_error_per_decade"]) == 3)
    few = os.path.join(tmp, "few.json")  # N = 20: lines at 500, 1000, 1500, 2000 Hz
    res = run("measure", "frf", "--scenario", scenario, "--from-hz", "500", "--to-hz", "2000", "--amplitude-v", "0.09",
              "--bias-v", "3", "--periods", "4", "--out", few)
    check("a 4-line response", res.returncode == 0 and len(json.load(open(few))["frequency_Hz"]) == 4, res.stderr)
    res = run("identify", "tf", "--frf", few, "--order", "4/3")
    check("order beyond the lines refused", res.returncode == 2 and "cannot support" in res.stderr, res.stderr)
    res = run("identify", "tf", "--frf", frf, "--order", "six")
    check("malformed order refused", res.returncode == 2 and "--order" in res.stderr, res.stderr)
    res = run("identify", "tf", "--frf", scenario, "--order", "2")
    check("not an frf file refused", res.returncode == 2 and "frequency_Hz" in res.stderr, res.stderr)

# 1b. Swept sine and PRBS (H1, Welch, coherence) on the same stage: within
# 0.5 dB and 3 deg wherever the coherence is >= 0.95 (the acceptance criterion).
def exact_response(f):
    model = json.load(open(os.path.join(configs, "models", "ahmad2020_G.json")))
    num = np.array(model["num"]) / model["num"][-1] * model["den"][-1]
    bd, ad, _ = signal.cont2discrete((num, np.array(model["den"])), 1e-4, method="zoh")
    z = np.exp(2j * np.pi * f * 1e-4)
    return 10.0 * 0.1159 * np.polyval(bd.ravel(), z) / np.polyval(ad, z)


for sig in ("sweep", "prbs"):
    out = os.path.join(tmp, f"{sig}.json")
    res = run("measure", "frf", "--scenario", scenario, "--signal", sig, "--from-hz", "10", "--to-hz", "4000",
              "--amplitude-v", "0.09", "--bias-v", "3", "--periods", "40", "--out", out)
    check(f"measure frf --signal {sig} runs", res.returncode == 0, res.stderr)
    if res.returncode != 0:
        continue
    j = json.load(open(out))
    f = np.array(j["frequency_Hz"])
    coh = np.array(j["coherence"])
    ratio = np.array([complex(a, b) for a, b in j["response"]]) / exact_response(f)
    ok = coh >= 0.95
    err_db = np.abs(20 * np.log10(np.abs(ratio[ok])))
    err_deg = np.abs(np.angle(ratio[ok], deg=True))
    print(f"     {sig}: {ok.sum()} of {len(f)} lines with coherence >= 0.95 (up to {f[ok].max():.0f} Hz): "
          f"max error {err_db.max():.3f} dB, {err_deg.max():.3f} deg; " + res.stderr.strip())
    check(f"{sig}: most lines coherent", ok.sum() >= 200, str(ok.sum()))
    check(f"{sig}: within 0.5 dB where coherent", err_db.max() <= 0.5, f"{err_db.max():.3f} dB")
    check(f"{sig}: within 3 deg where coherent", err_deg.max() <= 3.0, f"{err_deg.max():.3f} deg")
    check(f"{sig}: low coherence warned", any("coherence" in w for w in j["warnings"]) == bool((~ok).any()))

# 3. Hostile requests: exit 2, the option named, nothing written.
good = {"--from-hz": "10", "--to-hz": "4000", "--periods": "2", "--amplitude-v": "0.1", "--bias-v": "3"}
hostile = [
    ("amplitude + bias beyond the limits", {"--amplitude-v": "0.5", "--bias-v": "11.8"}, "--amplitude-v"),
    ("bias beyond the limits", {"--bias-v": "13"}, "--bias-v"),
    ("amplitude beyond the range", {"--amplitude-v": "100"}, "--amplitude-v"),
    ("F2 at Nyquist", {"--to-hz": "5000"}, "--to-hz"),
    ("F2 above Nyquist", {"--to-hz": "7000"}, "--to-hz"),
    ("F1 >= F2", {"--from-hz": "4000"}, "--from-hz"),
    ("F1 below what one period holds", {"--from-hz": "0.1"}, "--from-hz"),
    ("zero periods", {"--periods": "0"}, "--periods"),
    ("NaN amplitude", {"--amplitude-v": "nan"}, "--amplitude-v"),
    ("infinite bias", {"--bias-v": "inf"}, "--bias-v"),
    ("negative amplitude", {"--amplitude-v": "-0.1"}, "--amplitude-v"),
    ("closed loop without a case", {"--mode": "closed"}, "--case"),
    # Bounded plans: a Welch segment of at most 2^20 samples, a run of at
    # most 2,000,000 ticks (200 s at this scenario's 10 kHz).
    ("PRBS from 1 mHz", {"--signal": "prbs", "--from-hz": "0.001"}, "--from-hz"),
    ("sweep from 1 mHz", {"--signal": "sweep", "--from-hz": "0.001"}, "--from-hz"),
    ("sweep from 1e-300 Hz", {"--signal": "sweep", "--from-hz": "1e-300"}, "--from-hz"),
    ("PRBS just below the segment bound", {"--signal": "prbs", "--from-hz": "0.0095"}, "--from-hz"),
    ("sweep beyond the longest record", {"--signal": "sweep", "--from-hz": "0.05", "--periods": "100"}, "--periods"),
    ("multisine beyond the longest record", {"--periods": "10000"}, "--periods"),
]
for name, extra, option in hostile:
    out = os.path.join(tmp, "hostile.json")
    if os.path.exists(out):
        os.remove(out)
    args = dict(good, **extra)
    res = run("measure", "frf", "--scenario", scenario, *[x for kv in args.items() for x in kv], "--out", out)
    check(f"refused: {name}", res.returncode == 2 and option in res.stderr and not os.path.exists(out),
          f"exit {res.returncode}: {res.stderr.strip()}")

print("check_measure: " + ("FAILED" if failed else "all passed"))
sys.exit(1 if failed else 0)
