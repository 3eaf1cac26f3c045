#!/usr/bin/python3
"""Commissioning on stages nobody tuned for: random stages, one command each.

Draws --count stages from --seed, each a scenario file as a user would
write for their own stage (configs/scenarios.md), within the sizes real
piezo stages have (Devasia, Eleftheriou & Moheimani, IEEE TCST 15(5) 2007):

  actuator   a stack behind a x10..x20 amplifier (0..10 V in, unipolar) or a
             bender driven at +-10 V; 10..120 um of travel
  hysteresis a PI model of 5 play operators, the operators' weights 5..80 %
             of the elastic slope (loops of a few % to about 20 %)
  dynamics   a first mode at 300 Hz..8 kHz (zeta 0.005..0.08), a second one
             2.5..6x higher; the loop at 20, 50 or 100 kHz, at least 10x the
             first mode
  sensor     offset up to 2 % of the travel, gain error up to +-2 %, noise of
             20..100 ppm of the travel rms (a capacitive sensor's to a strain
             gauge's), half of them with 50 Hz mains pickup of 1..10 nm
  creep      0..3 % per decade (0.01..100 s), drift up to 0.05 um/s

and runs `piezoloop commission --scenario FILE --range-um R` on each, R 50..80 %
of the travel its PI model reaches. Prints one line per stage (what was drawn,
the chosen controller, the checks, or the reason it was refused or failed)
and a summary against the acceptance checks of docs/commissioning.md: the
10 Hz triangle over half the range within 1 % (2 % below a 500 Hz first mode)
and the 1 Hz triangle over the whole range within 1 %. Nothing is asserted:
a benchmark (minutes).

Usage: tools/bench_unseen_stages.py [--count N] [--seed S] [--piezoloop EXE]
                                    [--out DIR] [--json FILE]
"""
import argparse
import json
import math
import os
import random
import subprocess
import sys
import tempfile
import time

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))


def mode_poles(f_Hz, zeta):
    w = 2 * math.pi * f_Hz
    re, im = -zeta * w, w * math.sqrt(1 - zeta * zeta)
    return [[re, im], [re, -im]]


def draw_stage(rng, index):
    """A scenario dict, its first mode (Hz) and the range to ask for (um)."""
    stack = rng.random() < 0.6
    travel_um = rng.uniform(10, 120)
    if stack:
        gain = rng.choice([10, 15, 20])
        amp = {"gain": gain, "input_min_V": 0, "input_max_V": 10, "output_min_V": 0, "output_max_V": 10 * gain}
        span_V, u_lo, u_hi = 10.0 * gain, 0.0, 10.0
    else:
        amp = {"gain": 1, "input_min_V": -10, "input_max_V": 10, "output_min_V": -10, "output_max_V": 10}
        span_V, u_lo, u_hi = 20.0, -10.0, 10.0
    # PI model: thresholds spread over 60 % of the span, weights decaying.
    n = 5
    thresholds = [round(0.6 * span_V * ((j + 1) / (n + 1)) ** 1.3, 4) for j in range(n)]
    k = rng.uniform(0.05, 0.8)
    decay = rng.uniform(0.5, 0.9)
    raw = [decay ** j for j in range(n)]
    p0 = travel_um / span_V / (1 + k)
    weights = [round(k * p0 * r / sum(raw), 6) for r in raw]
    reach_um = p0 * span_V + sum(w * max(0.0, span_V - 2 * r) for w, r in zip(weights, thresholds))

    f1 = math.exp(rng.uniform(math.log(300), math.log(8000)))
    z1 = math.exp(rng.uniform(math.log(0.005), math.log(0.08)))
    f2 = f1 * rng.uniform(2.5, 6)
    z2 = rng.uniform(0.01, 0.1)
    rate = next(r for r in (20000, 50000, 100000) if r >= 10 * f1 and f2 < 0.45 * r) if f2 < 45000 else 100000
    poles = mode_poles(f1, z1) + mode_poles(min(f2, 0.45 * rate), z2)

    # Sensor: the travel within +-8 of the ADC's +-10 units.
    bipolar_reading = not stack
    gain_per_um = (16.0 if bipolar_reading else 8.0) / reach_um
    sensor = {
        "gain_per_um": round(gain_per_um, 6),
        "noise_rms": round(rng.uniform(20e-6, 100e-6) * reach_um * gain_per_um, 8),
        "seed": index + 1,
        "offset_um": round(rng.uniform(-0.02, 0.02) * reach_um, 4),
        "gain_error": round(rng.uniform(-0.02, 0.02), 4),
    }
    if rng.random() < 0.5:
        sensor["mains"] = {"frequency_Hz": 50, "amplitudes_um": [round(rng.uniform(0.001, 0.01), 4), 0.002]}
    plant = {
        "dac": {"bits": 16, "min": u_lo, "max": u_hi},
        "amplifier": amp,
        "hysteresis": {"kind": "pi", "thresholds_V": thresholds, "weights_um_per_V": weights,
                       "p0_um_per_V": round(p0, 6)},
        "dynamics": {"model": {"zeros": [], "poles": poles, "gain": 1.0}, "normalise_dc": True,
                     "discretisation": "zoh"},
        "sensor": sensor,
        "adc": {"bits": 16, "min": -10, "max": 10},
    }
    creep = rng.uniform(0, 3)
    if creep > 0.3:
        plant["creep"] = {"percent_per_decade": round(creep, 2), "from_s": 0.01, "to_s": 100}
    if rng.random() < 0.5:
        plant["drift_um_per_s"] = round(rng.uniform(0, 0.05), 4)
    name = "unseen_%02d" % index
    scenario = {
        "scenario": name,
        "title": "random stage %d" % index,
        "source": "tools/bench_unseen_stages.py",
        "loop": {"rate_Hz": rate, "position_full_scale_um": math.ceil(1.5 * reach_um),
                 "voltage_full_scale_V": 16,
                 "hard_limits": {"u_min_V": u_lo, "u_max_V": u_hi, "slew_V_per_s": 1.0e6}},
        "plant": plant,
        "reference": {"nominal_um_per_V": round(reach_um / span_V, 6), "offset": "unipolar" if stack else "bipolar"},
        "cases": [{"name": "open_loop", "label": "open loop",
                   "controller": {"feedforward": {"kind": "gain", "V_per_um": round(span_V / reach_um / amp["gain"], 6)}}}],
    }
    range_um = round(rng.uniform(0.5, 0.8) * reach_um, 1)
    drawn = ("%s %5.1f um, hyst k %.2f, mode %5.0f Hz z %.3f, %3.0f kHz, offset %+.2f um, gain err %+.1f %%%s%s" %
             ("stack " if stack else "bender", reach_um, k, f1, z1, rate / 1000, sensor["offset_um"],
              100 * sensor["gain_error"], ", mains" if "mains" in sensor else "",
              ", creep %.1f %%/dec" % plant["creep"]["percent_per_decade"] if "creep" in plant else ""))
    return scenario, f1, range_um, drawn


def main():
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--count", type=int, default=30)
    ap.add_argument("--seed", type=int, default=1)
    ap.add_argument("--piezoloop", default=os.path.join(ROOT, "build/host/host/piezoloop"))
    ap.add_argument("--out", default="", help="where the scenarios and each run's files go (default: a temporary folder)")
    ap.add_argument("--json", default="", help="write every result here")
    a = ap.parse_args()
    out = a.out or tempfile.mkdtemp(prefix="piezoloop_unseen_")
    os.makedirs(out, exist_ok=True)
    rng = random.Random(a.seed)
    results = []
    for i in range(a.count):
        scenario, f1, range_um, drawn = draw_stage(rng, i)
        path = os.path.join(out, scenario["scenario"] + ".json")
        with open(path, "w") as f:
            json.dump(scenario, f, indent=1)
        t0 = time.time()
        r = subprocess.run([a.piezoloop, "commission", "--scenario", path, "--range-um", str(range_um),
                            "--out", os.path.join(out, scenario["scenario"])], capture_output=True, text=True)
        wall = time.time() - t0
        res = {"stage": scenario["scenario"], "drawn": drawn, "range_um": range_um, "first_mode_Hz": f1,
               "exit": r.returncode, "wall_s": wall}
        if r.returncode == 0:
            s = json.loads(r.stdout)
            v = s.get("verification", [])
            res["chosen"] = s.get("chosen")
            res["verified"] = s.get("verified") is True
            res["check_pct"] = v[0]["measured"]["e_max_pct"] if v else None
            res["whole_pct"] = v[1]["measured"]["e_max_pct"] if len(v) > 1 else None
            limit = 2.0 if f1 < 500 else 1.0
            res["meets"] = bool(res["verified"] and res["check_pct"] is not None and res["check_pct"] <= limit
                                and res["whole_pct"] is not None and res["whole_pct"] <= 1.0)
            line = "%s: %s; %s, 10 Hz %.2f %% (<= %g), 1 Hz %.2f %%, %.1f s" % (
                res["stage"], drawn, res["chosen"], res["check_pct"] or -1, limit, res["whole_pct"] or -1, wall)
        else:
            # The reason: the error line, or the log's verdict (the lines
            # after it only name the figures written).
            lines = [x for x in r.stderr.strip().splitlines() if x.strip() and not x.startswith("wrote ")]
            res["reason"] = lines[-1] if lines else "(no message)"
            res["meets"] = False
            line = "%s: %s; exit %d: %s" % (res["stage"], drawn, r.returncode, res["reason"])
        print(line, flush=True)
        results.append(res)
    meets = sum(1 for x in results if x["meets"])
    verified = sum(1 for x in results if x.get("verified"))
    failed = [x for x in results if x["exit"] != 0]
    print("\n%d stages (seed %d): %d verified, %d meet both checks, %d not commissioned (each with its reason above); "
          "wall %.1f .. %.1f s" % (len(results), a.seed, verified, meets, len(failed),
                                    min(x["wall_s"] for x in results), max(x["wall_s"] for x in results)))
    if a.json:
        with open(a.json, "w") as f:
            json.dump(results, f, indent=1)
    return 0


if __name__ == "__main__":
    sys.exit(main())
