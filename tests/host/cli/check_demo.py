#!/usr/bin/python3
"""`piezoloop demo --json` on the reference stage: every controller part must
help, as docs/models.md, 'Stages and scenarios' expects of feedforward and feedback, in float and Q31.
Usage: check_demo.py PIEZOLOOP_BINARY"""
import json
import subprocess
import sys

exe = sys.argv[1]
passed = failed = 0
for sample in ("float", "q31"):
    res = subprocess.run([exe, "demo", "--json", "--sample", sample], capture_output=True, text=True)
    if res.returncode != 0:
        print(f"FAIL {sample}: exit {res.returncode}: {res.stderr}")
        failed += 1
        continue
    cases = {c["case"]: c for c in json.loads(res.stdout)["cases"]}
    open_loop = cases["open loop"]
    ff = cases["feedforward (inverse PI)"]
    both = cases["feedforward + feedback"]
    checks = [
        ("feedforward lowers hysteresis", ff["hysteresis_pct"] < open_loop["hysteresis_pct"]),
        ("feedforward + feedback lowers it further", both["hysteresis_pct"] < ff["hysteresis_pct"]),
        ("feedforward + feedback beats feedforward", both["e_max_pct"] < ff["e_max_pct"]),
        ("peak error below 1 % at 10 Hz", both["e_max_pct"] < 1.0),
    ]
    for name, ok in checks:
        if ok:
            passed += 1
        else:
            failed += 1
            print(f"FAIL {sample}: {name}: {json.dumps(cases)}")
bad = subprocess.run([exe, "demo", "--frequency-hz", "1e6"], capture_output=True, text=True)
if bad.returncode != 0 and "frequency-hz" in bad.stderr:
    passed += 1
else:
    failed += 1
    print(f"FAIL out-of-range frequency accepted: {bad.returncode} {bad.stderr!r}")
print(f"{passed} passed, {failed} failed")
sys.exit(1 if failed else 0)
