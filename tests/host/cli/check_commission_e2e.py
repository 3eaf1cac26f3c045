#!/usr/bin/python3
"""`piezoloop --device ADDR commission` end to end on an emulated qemu-m7
board whose stage only the emulator reads: configs/stages/
stiff_stack_unipolar.json (first mode 2.1 kHz, 50 kHz loop, an amplifier
with input -1..11 V, a capacitive sensor with an offset and a gain error read
by a unipolar 0..10 V ADC: the stage whose whole-range triangles once sat at
the sensor's rail on a board while the simulator verified):

  emulate --storage F; set limits 0..10 V (the stage's amplifier input);
  commission --range-um 100   -> exit 2 naming --range-um, disarmed, nothing stored
  commission --range-um 12    -> exit 0: a candidate chosen with PM >= 45 deg,
      GM >= 6 dB and max|S| <= 2 on the measured response; the 10 Hz triangle
      over half the range tracked on the board with e_max <= 1 % and the 1 Hz
      triangle over the whole range too (the acceptance checks); verified and
      saved; the board disarmed, its trajectory group
      put back; the files written
  (stop the board, start it again with F)
      -> status: the stored set applied at boot, disarmed; the feedback group
         is the commissioned one.
  the same stage with its sensor's sign reversed: commission exits 1 at the
  first safety step saying so, the board disarmed and unchanged.

Usage: check_commission_e2e.py PIEZOLOOP SERVO_ELF CONFIGS_DIR
Exit 77 (skipped) without qemu-system-arm or the image."""
import json
import os
import subprocess
import sys
import tempfile

from board_checks import Checks, Emulators, skip_without_qemu

exe, image, configs = sys.argv[1], sys.argv[2], sys.argv[3]
skip_without_qemu(image)

stage = os.path.join(configs, "stages", "stiff_stack_unipolar.json")
tmp = tempfile.mkdtemp(prefix="check_commission_e2e_")
store = os.path.join(tmp, "params.bin")
out = os.path.join(tmp, "out")
check = Checks()
emulators = Emulators(exe)
stop = Emulators.stop


def run(*args, timeout=60):
    return subprocess.run([exe, *args], capture_output=True, text=True, timeout=timeout)


def status(d):
    r = run(*d, "status")
    return json.loads(r.stdout).get("status", {}) if r.returncode == 0 else {}


try:
    emu, d, info = emulators.start("--board", "qemu-m7", "--scenario", stage, "--image", image, "--storage", store)
    r = run(*d, "set", "limits", "--json", '{"u_min_V": 0, "u_max_V": 10, "slew_V_per_s": 200000}')
    check(r.returncode == 0, "set limits 0..10 V", r.stderr)

    r = run(*d, "commission", "--range-um", "100", "--out", out)
    check(r.returncode == 2 and "--range-um" in r.stderr, "a range beyond the travel: exit 2 naming --range-um",
          r.stderr)
    check(not os.path.exists(out), "nothing written for a refused request")
    check(status(d).get("armed") is False and os.path.getsize(store) == 0, "disarmed, nothing stored")

    trajectory = run(*d, "get", "trajectory").stdout
    r = run(*d, "commission", "--range-um", "12", "--out", out, timeout=240)
    j = json.loads(r.stdout) if r.returncode == 0 else {}
    check(r.returncode == 0 and j.get("verified") is True and j.get("saved") is True,
          "commission on the board: verified and saved", r.stderr[-2000:])
    chosen = next((k for k in j.get("candidates", []) if k["name"] == j.get("chosen")), {})
    check((chosen.get("measured_phase_margin_deg") or 0) >= 45 and
          (chosen.get("measured_gain_margin_db") is None or chosen["measured_gain_margin_db"] >= 6) and
          0 < chosen.get("measured_max_sensitivity", 9) <= 2,
          "the chosen controller meets PM >= 45, GM >= 6 dB, max|S| <= 2 on the measured response",
          json.dumps(chosen)[:400])
    v = j.get("verification", [{}])[0]
    check(v.get("frequency_Hz") == 10 and v.get("range_um") == 6 and v.get("measured", {}).get("e_max_pct", 99) <= 1.0,
          "10 Hz triangle over half the range on the board: e_max <= 1 %", json.dumps(v))
    w = (j.get("verification") or [{}, {}])[1] if len(j.get("verification") or []) > 1 else {}
    check(w.get("frequency_Hz") == 1 and w.get("range_um") == 12 and w.get("measured", {}).get("e_max_pct", 99) <= 1.0,
          "1 Hz triangle over the whole range on the board: e_max <= 1 %", json.dumps(w))
    print(f"board: e_max {v.get('measured', {}).get('e_max_pct')} % (predicted {v.get('predicted', {}).get('e_max_pct')} %), "
          f"1 Hz whole range {w.get('measured', {}).get('e_max_pct')} % (predicted {w.get('predicted', {}).get('e_max_pct')} %), "
          f"wall {j.get('wall_s')} s")
    for name in ("report.md", "controller.json", "frf.json", "scenario.json"):
        check(os.path.exists(os.path.join(out, name)), f"{name} written")
    # The fastest whole-range triangle within 1 %: at least the 1 Hz run, as
    # the board's own runs give it, and in the report.
    fastest = j.get("fastest_triangle") or {}
    report = open(os.path.join(out, "report.md")).read() if os.path.exists(os.path.join(out, "report.md")) else ""
    check(fastest.get("up_to_Hz", 0) >= 1 and ("Fastest triangle: " + fastest.get("text", "?")) in report,
          "the fastest whole-range triangle within 1 % on the board, in the report", json.dumps(fastest))
    print(f"board: {fastest.get('text')}")
    s = status(d)
    check(s.get("armed") is False, "the board is left disarmed")
    check(run(*d, "get", "trajectory").stdout == trajectory, "the trajectory group is put back")
    feedback = run(*d, "get", "feedback").stdout
    check(stop(emu) == 0, "SIGTERM ends the board")

    emu, d, info = emulators.start("--board", "qemu-m7", "--scenario", stage, "--image", image, "--storage", store)
    s = status(d)
    check(info.get("storage_at_boot") == "applied" and s.get("storage", {}).get("at_boot") == "applied",
          "reboot: the commissioned set is applied at boot", json.dumps(s.get("storage")))
    check(s.get("armed") is False, "reboot: disarmed")
    check(run(*d, "get", "feedback").stdout == feedback, "reboot: the feedback group is the commissioned one")
    # The identified stage reproduces on the host.
    r = run("sim", "--scenario", os.path.join(out, "scenario.json"), "--case", "commissioned", "--amplitude-um", "2",
            "--frequency-hz", "10")
    check(r.returncode == 0, "sim runs the written scenario's commissioned case", r.stderr)
    check(stop(emu) == 0, "SIGTERM ends the rebooted board")

    # The same stage moving the wrong way for the controller (its dynamics'
    # DC gain -1.7, an ADC that reads both signs): the first safety step stops
    # the commissioning, exit 1 saying the sensor's sign is reversed; the
    # board is left disarmed with its groups as they were.
    reversed_stage = json.load(open(stage))
    dynamics = reversed_stage["plant"]["dynamics"]
    dc = 1.0
    for re_, im in dynamics["model"]["poles"]:
        dc *= abs(complex(re_, im))
    for re_, im in dynamics["model"].get("zeros", []):
        dc /= abs(complex(re_, im))
    dynamics["normalise_dc"] = False
    dynamics["model"]["gain"] = -1.7 * dc
    reversed_stage["plant"]["adc"]["min"] = -10
    reversed_file = os.path.join(tmp, "reversed.json")
    json.dump(reversed_stage, open(reversed_file, "w"))
    emu, d, info = emulators.start("--board", "qemu-m7", "--scenario", reversed_file, "--image", image)
    r = run(*d, "set", "limits", "--json", '{"u_min_V": 0, "u_max_V": 10, "slew_V_per_s": 200000}')
    feedback = run(*d, "get", "feedback").stdout
    r = run(*d, "commission", "--range-um", "4", "--out", os.path.join(tmp, "reversed_out"), timeout=120)
    check(r.returncode == 1 and "safety step of" in r.stderr and "sign is reversed" in r.stderr,
          "a reversed sensor on the board: exit 1 at the first safety step", r.stderr[-600:])
    check(status(d).get("armed") is False and run(*d, "get", "feedback").stdout == feedback,
          "the reversed stage's board is left disarmed, its feedback group unchanged")
finally:
    emulators.stop_all()
check.exit()
