#!/usr/bin/python3
"""`piezoloop sim` and `piezoloop reproduce` end to end.

 - sim prints the metrics (docs/models.md, 'Metrics') as JSON; the same run twice gives the same
   log hash; the run replayed by two separately compiled probes (-O0, -O2,
   tests/host/sim/sim_hash_probe.cpp) gives that hash too (cross-build
   determinism), for float and Q31 cores and for the series
   inverse (the core's pi_series);
 - --out writes the CSV log, --hash prints only the hash;
 - a scenario with a bad field is refused with the field path;
 - reproduce writes report.md with the tables and figures.json.
Usage: check_sim.py PIEZOLOOP PROBE_O0 PROBE_O2 CONFIGS_DIR"""
import csv
import json
import os
import subprocess
import sys
import tempfile

exe, probe0, probe2, configs = sys.argv[1:5]
passed = failed = 0


def check(name, ok, detail=""):
    global passed, failed
    if ok:
        passed += 1
    else:
        failed += 1
        print(f"FAIL {name}: {detail}")


def run(args):
    return subprocess.run([exe] + args, capture_output=True, text=True)


tmp = tempfile.mkdtemp(prefix="check_sim_")
runs = [
    # scenario, case, extra arguments
    ("ahmad2020", "dahl_ff_K", ["--frequency-hz", "20", "--amplitude-um", "12", "--duration-s", "0.1"]),
    ("janaideh2016", "ff_fb", ["--trajectory", "sine", "--frequency-hz", "10", "--amplitude-um", "40"]),
    ("janaideh2016", "ff", ["--trajectory", "sine", "--frequency-hz", "10", "--amplitude-um", "40", "--sample", "q31"]),
    ("shan2012", "pi_rc", ["--frequency-hz", "1000", "--amplitude-um", "10", "--duration-s", "0.02"]),
    ("shan2012", "pi_rc", ["--frequency-hz", "1000", "--amplitude-um", "10", "--duration-s", "0.02", "--sample", "q31"]),
    ("shan2012", "pi_rc_inv", ["--frequency-hz", "1000", "--amplitude-um", "10", "--duration-s", "0.02"]),
]
for scen, case, extra in runs:
    tag = f"{scen}/{case} {' '.join(extra)}"
    base = ["sim", "--scenario", os.path.join(configs, scen + ".json"), "--case", case] + extra
    dump = os.path.join(tmp, f"{scen}_{case}.dump")
    a = run(base + ["--dump-model", dump])
    b = run(base)
    if a.returncode != 0 or b.returncode != 0:
        check(tag, False, a.stderr + b.stderr)
        continue
    ja, jb = json.loads(a.stdout), json.loads(b.stdout)
    keys = ["hysteresis_pct", "e_max_pct", "e_rms_pct", "e_max_um", "e_rms_um", "realtime_factor", "log_hash"]
    check(f"{tag}: JSON fields", all(k in ja for k in keys), a.stdout)
    check(f"{tag}: e_max_um / range = e_max_pct",
          abs(ja["e_max_um"] / ja["trajectory"]["range_um"] * 100 - ja["e_max_pct"]) < 1e-9 * max(1.0, ja["e_max_pct"]),
          a.stdout)
    check(f"{tag}: two runs, same hash", ja["log_hash"] == jb["log_hash"], f"{ja['log_hash']} {jb['log_hash']}")
    for probe in (probe0, probe2):
        p = subprocess.run([probe, dump], capture_output=True, text=True)
        check(f"{tag}: {os.path.basename(probe)} replays the same hash",
              p.returncode == 0 and p.stdout.strip() == ja["log_hash"], f"{p.stdout.strip()} vs {ja['log_hash']} {p.stderr}")
    h = run(base + ["--hash"])
    check(f"{tag}: --hash", h.returncode == 0 and h.stdout.strip() == ja["log_hash"], h.stdout)

# A changed parameter changes the hash (the hash can fail).
sh = ["sim", "--scenario", os.path.join(configs, "shan2012.json"), "--frequency-hz", "1000", "--amplitude-um", "10",
      "--duration-s", "0.01", "--hash"]
h1, h2 = run(sh + ["--case", "pi_rc"]), run(sh + ["--case", "pi_rc_m1_6"])
check("different case, different hash", h1.stdout.strip() != h2.stdout.strip() and h1.returncode == 0, h1.stdout + h2.stdout)

# CSV log.
out = os.path.join(tmp, "log.csv")
r = run(["sim", "--scenario", os.path.join(configs, "ahmad2020.json"), "--case", "open_loop",
         "--frequency-hz", "10", "--amplitude-v", "40", "--out", out])
rows = list(csv.DictReader(open(out))) if r.returncode == 0 and os.path.exists(out) else []
check("--out writes every tick", len(rows) == 2000, f"{len(rows)} rows, {r.stderr}")
if rows:
    v = max(float(x["v_piezo_V"]) for x in rows)
    check("--amplitude-v drives the piezo to the given voltage", abs(v - 40.0) < 0.01, f"max piezo voltage {v}")

# Validation errors name the field path.
bad = json.load(open(os.path.join(configs, "shan2012.json")))
bad["cases"][2]["controller"]["rc"]["k_rc"] = 2.5
bad_path = os.path.join(tmp, "bad.json")
# Model files are resolved next to the scenario: keep the inline models only.
json.dump(bad, open(bad_path, "w"))
r = run(["sim", "--scenario", bad_path, "--case", "pi", "--frequency-hz", "1000", "--amplitude-um", "10"])
check("bad k_rc refused with its path (exit 2)", r.returncode == 2 and "cases[2].controller.rc.k_rc: must be in (0, 2)" in r.stderr,
      r.stderr)
r = run(["sim", "--scenario", os.path.join(configs, "shan2012.json"), "--case", "nope", "--amplitude-um", "1"])
check("unknown case refused (exit 2)", r.returncode == 2 and "no such case" in r.stderr, r.stderr)

# reproduce (the quickest source), without drawing.
rep = os.path.join(tmp, "rep")
r = run(["reproduce", "ahmad2020", "--out", rep, "--no-plots", "--configs", configs])
report = open(os.path.join(rep, "report.md")).read() if r.returncode == 0 else ""
check("reproduce writes report.md", "| Hysteresis % | 10 V | 20 V | 30 V | 40 V |" in report, r.stderr[-500:])
figs = json.load(open(os.path.join(rep, "figures.json"))) if r.returncode == 0 else []
check("reproduce lists its figures", len(figs) >= 3 and all("panels" in f for f in figs), str(len(figs)))

print(f"{passed} passed, {failed} failed")
sys.exit(1 if failed else 0)
