#!/usr/bin/python3
"""End to end: `piezoloop commission --scenario configs/ahmad2020.json
--range-um 12 --out DIR` writes report.md, controller.json, frf.json,
scenario.json and the figures; the chosen controller passes `piezoloop
analyze measured-loop` on the written measurement with the figures the
summary reports (same lines, same discretisation: equal to 1e-9); the
written scenario's commissioned case runs in `piezoloop sim`; the
verification agrees; bad requests exit 2 naming the option, with nothing
written; the three stages of configs/stages/ meet the tracking check; a
stage that does not respond stops at the first safety step;
options for a board only are refused on the simulator.
Usage: check_commission.py PIEZOLOOP_BINARY CONFIGS_DIR
"""
import json
import os
import subprocess
import sys
import tempfile

exe, configs = sys.argv[1], sys.argv[2]
tmp = tempfile.mkdtemp()
passed = failed = 0


def check(ok, what):
    global passed, failed
    if ok:
        passed += 1
    else:
        failed += 1
        print("FAIL", what)


scenario = os.path.join(configs, "ahmad2020.json")
out = os.path.join(tmp, "c")
r = subprocess.run([exe, "commission", "--scenario", scenario, "--range-um", "12", "--out", out],
                   capture_output=True, text=True)
check(r.returncode == 0, "commission: %d %s" % (r.returncode, r.stderr))
if r.returncode == 0:
    s = json.loads(r.stdout)
    for name in ("report.md", "controller.json", "frf.json", "scenario.json", "frf.png", "loops.png",
                 "candidates.png", "verification.png"):
        check(os.path.exists(os.path.join(out, name)), name)
    check(s.get("verified") is True and s["verification"][0]["frequency_Hz"] == 10 and
          s["verification"][0]["range_um"] == 6, "verified, the check first: %r" % s.get("verification"))
    r2 = subprocess.run([exe, "sim", "--scenario", os.path.join(out, "scenario.json"), "--case", "commissioned",
                         "--amplitude-um", "6", "--frequency-hz", "10"], capture_output=True, text=True)
    check(r2.returncode == 0 and json.loads(r2.stdout)["e_max_pct"] < 5, "sim of scenario.json: %s" % r2.stderr)
    chosen = [c for c in s["candidates"] if c["name"] == s["chosen"]][0]
    check(chosen["passes"] and chosen["measured_phase_margin_deg"] >= 45, "chosen passes: %r" % chosen["name"])
    m = subprocess.run([exe, "analyze", "measured-loop", "--frf", os.path.join(out, "frf.json"), "--controller",
                        os.path.join(out, "controller.json")], capture_output=True, text=True)
    check(m.returncode == 0, "measured-loop: %d %s" % (m.returncode, m.stderr))
    if m.returncode == 0:
        ml = json.loads(m.stdout)
        pm = ml["phase_margin"]["phase_margin_deg"]
        check(abs(pm - chosen["measured_phase_margin_deg"]) <= 1e-9 * abs(pm), "PM %r vs %r" % (pm, chosen))
    check("**chosen**" in open(os.path.join(out, "report.md")).read(), "report names the chosen one")

for args, option in ((["--range-um", "1000"], "--range-um"), (["--range-um", "-1"], "--range-um"),
                     (["--range-um", "nan"], "--range-um"),
                     (["--range-um", "12", "--target-bandwidth-hz", "4000"], "--target-bandwidth-hz"),
                     (["--range-um", "12", "--target-bandwidth-hz", "-5"], "--target-bandwidth-hz")):
    bad = os.path.join(tmp, "bad")
    r = subprocess.run([exe, "commission", "--scenario", scenario, *args, "--out", bad], capture_output=True, text=True)
    check(r.returncode == 2 and option in r.stderr and not os.path.exists(bad),
          "%s: %d %s" % (option, r.returncode, r.stderr))

# The three stages of configs/stages/ the tool has not seen meet the issue's
# tracking check on the simulator: a 10 Hz triangle over half the range with
# e_max <= 1 % of its range, <= 2 % where the first mode is below 500 Hz (the
# soft bender's is at 400 Hz). (The stiff stack on qemu-m7:
# check_commission_e2e.py.)
for stage, range_um, limit in (("stiff_stack", 12, 1.0), ("soft_bender", 24, 2.0), ("rhp_zero", 20, 1.0)):
    o = os.path.join(tmp, stage)
    r = subprocess.run([exe, "commission", "--scenario", os.path.join(configs, "stages", stage + ".json"), "--range-um",
                        str(range_um), "--out", o], capture_output=True, text=True)
    s = json.loads(r.stdout) if r.returncode == 0 else {}
    e = s.get("verification", [{}])[0].get("measured", {}).get("e_max_pct", 99)
    check(r.returncode == 0 and s.get("verified") is True and e <= limit,
          "%s: verified, 10 Hz over half the range e_max %.3g %% <= %g %%: %s" % (stage, e, limit, r.stderr[-300:]))
    print("%s: %s, e_max %.3g %%" % (stage, s.get("chosen"), e))

# A stage that does not move (its dynamics' gain 1e-9): the first safety step
# stops it, exit 1 naming the step and the reason, nothing written.
dead = json.load(open(os.path.join(configs, "stages", "stiff_stack.json")))
dead["plant"]["dynamics"]["normalise_dc"] = False
dead["plant"]["dynamics"]["model"]["gain"] = 1e-9
dead_file = os.path.join(tmp, "dead.json")
json.dump(dead, open(dead_file, "w"))
r = subprocess.run([exe, "commission", "--scenario", dead_file, "--range-um", "10", "--out", bad], capture_output=True,
                   text=True)
check(r.returncode == 1 and "safety step of 0.2 V" in r.stderr and "does not respond" in r.stderr and
      not os.path.exists(bad), "a stage that does not respond: %d %s" % (r.returncode, r.stderr))

r = subprocess.run([exe, "commission", "--scenario", scenario, "--range-um", "12", "--no-save", "--out", bad],
                   capture_output=True, text=True)
check(r.returncode == 2 and "--no-save" in r.stderr, "--no-save on the simulator: %s" % r.stderr)

print("%d passed, %d failed" % (passed, failed))
sys.exit(1 if failed else 0)
