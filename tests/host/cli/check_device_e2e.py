#!/usr/bin/python3
"""The host link end to end against an emulated board (qemu-m7, float core;
qemu-m3, Q31 core: janaideh2016 / ff_fb, 0.2 s of a 20 um triangle at
100 kHz against `piezoloop sim --sample q31`, r, y, u and the hash; e is not
compared there because the simulator's CSV prints e as r - y in physical
float while the board records the core's Q31 e):

  piezoloop emulate --board qemu-m7 --scenario configs/ahmad2020.json
  piezoloop --device tcp:... set --scenario ahmad2020.json --case dahl_ff_K
  piezoloop --device tcp:... record --start-wave --restart-stage  (1 s of the
      12 um 10 Hz triangle, r, y, e, u)

must give r, y, e, u equal bit for bit to
  piezoloop sim --scenario ahmad2020.json --case dahl_ff_K --trajectory triangle
      --frequency-hz 10 --amplitude-um 12 --duration-s 1 --out sim.csv
(the CSVs print floats with 9 significant digits, which identify a float
exactly), the same log_hash and metrics (docs/models.md), and zero lost blocks. A
second record from rest repeats the first exactly. Also: get all / set all
round trip, a rejected group prints the device's error naming the field and
exits non-zero, a streamed wave is consumed completely, wave start/stop, and
SIGTERM to `emulate` ends QEMU.

qemu-m7-100k: the same Ahmad2020 stage and dahl_ff_K controller on qemu-m7
at 100 kHz (the scenario with loop.rate_Hz = 100000, written to a scratch
file), 0.2 s: K(s)'s slow pole pair at |z| = 0.99997 runs in the float
core's delta-operator sections, and board and simulator agree bit for bit.

Usage: check_device_e2e.py PIEZOLOOP SERVO_ELF CONFIGS_DIR [qemu-m7|qemu-m3|qemu-m7-100k]
Exit 77 (skipped) without qemu-system-arm or the image."""
import csv
import json
import os
import shutil
import signal
import subprocess
import sys
import tempfile
import time

exe, image, configs = sys.argv[1], sys.argv[2], sys.argv[3]
variant = sys.argv[4] if len(sys.argv) > 4 else "qemu-m7"
board = "qemu-m7" if variant == "qemu-m7-100k" else variant
tmp = tempfile.mkdtemp(prefix="check_device_e2e_")
if variant == "qemu-m7-100k":
    with open(os.path.join(configs, "ahmad2020.json")) as f:
        sc = json.load(f)
    sc["loop"]["rate_Hz"] = 100000
    sc["plant"]["dynamics"]["model"] = os.path.join(configs, sc["plant"]["dynamics"]["model"])
    for c in sc["cases"]:
        fb = c.get("controller", {}).get("feedback", {})
        if "model" in fb:
            fb["model"] = os.path.join(configs, fb["model"])
    scenario = os.path.join(tmp, "ahmad2020_100k.json")
    with open(scenario, "w") as f:
        json.dump(sc, f)
    case, rate, seconds, range_um = "dahl_ff_K", 100000, 0.2, "12"
    sim_sample, columns, stream_s = "float", ("t_s", "r_um", "y_um", "e_um", "u_V"), "0.05"
elif board == "qemu-m7":
    scenario, case, rate, seconds, range_um = os.path.join(configs, "ahmad2020.json"), "dahl_ff_K", 10000, 1, "12"
    sim_sample, columns, stream_s = "float", ("t_s", "r_um", "y_um", "e_um", "u_V"), "0.3"
else:
    scenario, case, rate, seconds, range_um = os.path.join(configs, "janaideh2016.json"), "ff_fb", 100000, 0.2, "20"
    sim_sample, columns, stream_s = "q31", ("t_s", "r_um", "y_um", "u_V"), "0.05"
frames = int(round(rate * seconds))
stream_n = int(round(rate * float(stream_s)))
if not os.path.exists(image) or shutil.which(os.environ.get("QEMU_SYSTEM_ARM", "qemu-system-arm")) is None:
    print(f"skipped: no QEMU or no image {image}")
    shutil.rmtree(tmp, ignore_errors=True)
    sys.exit(77)

passed = failed = 0


def check(ok, what, detail=""):
    global passed, failed
    if ok:
        passed += 1
        print("ok   " + what)
    else:
        failed += 1
        print("FAIL " + what + (f": {detail}" if detail else ""))
    return ok


def run(*args, timeout=300):
    r = subprocess.run([exe, *args], capture_output=True, text=True, timeout=timeout)
    return r


emu = subprocess.Popen([exe, "emulate", "--board", board, "--scenario", scenario, "--image", image],
                       stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
try:
    line = emu.stdout.readline()
    info = json.loads(line)
    dev = info["device"]
    check(info["board"] == board and info["loop_rate_Hz"] == rate and info["firmware"]["loop_rate_Hz"] == rate,
          f"emulate: {board} up at the scenario's {rate} Hz", line)
    d = ["--device", dev]

    st = run(*d, "status")
    s = json.loads(st.stdout)
    check(st.returncode == 0 and s["hello"]["board"] == board and s["status"]["tick"]["board_faults"] == 0,
          "status: hello and no board fault (profile accepted)", st.stderr)

    r = run(*d, "set", "--scenario", scenario, "--case", case, "--frequency-hz", "10")
    j = json.loads(r.stdout) if r.returncode == 0 else {}
    check(r.returncode == 0 and {"limits", "feedforward", "feedback"} <= set(j.get("sent", [])),
          "set --scenario: limits, feedforward, feedback sent", r.stderr)
    if board == "qemu-m7":
        # The scenario allows 12 V and 1e6 V/s, the QEMU board 10 V and 2e5 V/s.
        check("clipped: limits.u_max_V: 12 -> 10" in r.stderr and len(j.get("clipped", [])) >= 1,
              "set --scenario: limits beyond the board's hard limits clipped and reported", r.stderr)
    else:
        check("built for this board's q31" in r.stderr and j.get("clipped") == [],
              "set --scenario: the float case is built for the Q31 board (its SOS scaling), nothing clipped",
              r.stderr)

    g = run(*d, "get", "all")
    groups = json.loads(g.stdout)
    check(g.returncode == 0 and groups["feedforward"]["kind"] in ("dahl", "pi_inverse", "pi_compensator") and
          groups["feedback"]["kind"] == "sos",
          "get all: the case's controller is on the board")
    # The board's groups conform to the published schema (an independent
    # validator: python3-jsonschema).
    import jsonschema
    schema = json.loads(run("schema").stdout)
    invalid = [f"{name}: {e.message}" for name in groups if name in schema["properties"]
               for e in jsonschema.Draft202012Validator(schema["properties"][name]).iter_errors(groups[name])]
    check(set(schema["properties"]) <= set(groups) and not invalid, "get all conforms to `piezoloop schema`",
          "; ".join(invalid))
    path = os.path.join(tmp, "all.json")
    with open(path, "w") as f:
        json.dump(groups, f)
    r = run(*d, "set", "all", "--json", path)
    g2 = run(*d, "get", "all")
    check(r.returncode == 0 and json.loads(g2.stdout) == groups, "set all --json (get all's output) changes nothing",
          r.stderr)

    # One axis: --axis x is that axis, another is refused naming the choices
    # (exit 2) before anything is sent; the matrices are the 1 x 1 identity.
    gx = run(*d, "get", "limits", "--axis", "x")
    check(gx.returncode == 0 and json.loads(gx.stdout) == groups["limits"], "get limits --axis x: the only axis")
    ry = run(*d, "wave", "--axis", "y", "--amplitude-um", "1")
    check(ry.returncode == 2 and "--axis" in ry.stderr and "1 axes" in ry.stderr,
          "wave --axis y on a one-axis board: exit 2 naming the choices", ry.stderr)
    check(groups["output_matrix"]["axis_count"] == 1 and groups["output_matrix"]["gain"][0] == 1.0,
          "output_matrix: the 1 x 1 identity", str(groups["output_matrix"]))

    r = run(*d, "set", "limits", "--json", '{"u_max_V": 50}')
    check(r.returncode == 3 and "SetParams refused (invalid_param): limits.u_max_V:" in r.stderr,
          "a rejected group prints the device's error and exits non-zero", r.stderr)
    r = run(*d, "set", "feedforward", "--json", '{"pi": {"thresholds": [1, 0.5], "weights": [1, 1]}}')
    check(r.returncode == 3 and "pi.thresholds[1]: must be strictly ascending" in r.stderr,
          "an array element is named with its index", r.stderr)

    rec_csv, sim_csv = os.path.join(tmp, "rec.csv"), os.path.join(tmp, "sim.csv")
    wave = ["--trajectory", "triangle", "--frequency-hz", "10", "--amplitude-um", range_um]
    records = []
    for attempt in range(2):
        out = rec_csv if attempt == 0 else rec_csv + ".2"
        r = run(*d, "record", "--signals", "r,y,e,u", "--duration-s", str(seconds), *wave, "--scenario", scenario,
                "--start-wave", "--restart-stage", "--out", out)
        j = json.loads(r.stdout) if r.stdout.strip() else {}
        records.append(j)
        # A wave away from the stage (janaideh2016's bipolar one) is
        # approached first: the record is longer by the approach's ticks.
        check(r.returncode == 0 and j.get("frames") == frames + j.get("approach_ticks", -1) and
              j.get("lost_blocks") == 0 and
              j.get("out_of_order") == 0 and j.get("tick_gaps") == 0 and j.get("recorder_overruns") == 0,
              f"record {attempt + 1}: {frames} frames after the approach, nothing lost", r.stderr + json.dumps(j))
    sim = run("sim", "--scenario", scenario, "--case", case, "--sample", sim_sample, *wave, "--duration-s",
              str(seconds), "--out", sim_csv)
    sj = json.loads(sim.stdout)
    check(sim.returncode == 0, "piezoloop sim ran", sim.stderr)
    with open(rec_csv) as f:
        rec = list(csv.DictReader(f))
    with open(sim_csv) as f:
        ref = list(csv.DictReader(f))
    diff = [i for i, (a, b) in enumerate(zip(rec, ref)) if any(a[c] != b[c] for c in columns)]
    check(len(rec) == len(ref) == frames + records[0].get("approach_ticks", -1) and not diff,
          f"record {', '.join(columns)} equal `piezoloop sim --sample {sim_sample}` bit for bit",
          f"{len(rec)} vs {len(ref)} rows, first difference at row {diff[0] if diff else None}")
    check(records[0].get("log_hash") == sj["log_hash"], "record log_hash equals `piezoloop sim`'s",
          f"{records[0].get('log_hash')} vs {sj['log_hash']}")
    check(all(records[0].get(k) == sj[k] for k in ("e_max_um", "e_rms_um", "hysteresis_pct")),
          "metrics over the last period equal the simulator's")
    check(records[1].get("log_hash") == records[0].get("log_hash"), "a second record from rest repeats the first")

    r = run(*d, "disarm")
    r = run(*d, "wave", "--stop")
    r = run(*d, "stream", *wave, "--duration-s", stream_s)
    j = json.loads(r.stdout) if r.returncode == 0 else {}
    check(r.returncode == 0 and j.get("consumed") == stream_n and j.get("sent") == stream_n and j.get("drained"),
          f"stream: {stream_n} generated setpoints consumed, drained", r.stderr + r.stdout)
    st = json.loads(run(*d, "status").stdout)["status"]
    check(not st["streaming"] and st["setpoint_underruns"] == j.get("underruns"),
          "stream: underruns reported as the device counts them")

    r = run(*d, "wave", "--trajectory", "sine", "--frequency-hz", "5", "--amplitude-um", "4")
    j = json.loads(r.stdout) if r.returncode == 0 else {}
    check(r.returncode == 0 and j.get("wave_running") and j["trajectory"]["waveform"] == "sine",
          "wave: sine started", r.stderr)
    r = run(*d, "wave", "--stop")
    check(r.returncode == 0 and not json.loads(r.stdout)["wave_running"], "wave --stop", r.stderr)

    # A killed stream client: the board closes the stream itself when the
    # link stays silent (docs/protocol.md, "Client loss"); waves work again.
    # The board serves one client at a time, so it is asked only after the
    # kill; a client killed before its stream started is tried again later.
    # A short timeout: an emulated board's clock runs slower than the host's.
    r = run(*d, "set", "link", "--json", '{"client_timeout_s": 0.05}')
    check(r.returncode == 0, "set link: client_timeout_s", r.stderr)
    st = {}
    for wait_s in (2, 5, 10):
        killed = subprocess.Popen([exe, *d, "stream", *wave, "--duration-s", "60"],
                                  stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
        time.sleep(wait_s)
        killed.kill()
        killed.wait()
        deadline = time.time() + 30
        while time.time() < deadline:
            r = run(*d, "status")
            st = json.loads(r.stdout)["status"] if r.returncode == 0 else {}
            if st and not st["streaming"]:
                break
            time.sleep(0.2)
        if "client_lost" in st.get("faults", []):
            break
    check(not st.get("streaming", True) and "client_lost" in st.get("faults", []),
          "a killed stream client: the board closes its stream and reports client_lost", json.dumps(st))
    r = run(*d, "wave", "--trajectory", "sine", "--frequency-hz", "5", "--amplitude-um", "4")
    check(r.returncode == 0 and json.loads(r.stdout).get("wave_running"), "wave after a lost client", r.stderr)
    r = run(*d, "stop")
    j = json.loads(r.stdout) if r.returncode == 0 else {}
    check(r.returncode == 0 and not j.get("wave_running", True) and not j.get("streaming", True), "stop", r.stderr)

    qemu_pid = info["pid"]
    emu.send_signal(signal.SIGTERM)
    rc = emu.wait(timeout=20)
    time.sleep(0.2)
    gone = not os.path.exists(f"/proc/{qemu_pid}") or open(f"/proc/{qemu_pid}/stat").read().split()[2] == "Z"
    check(rc == 0 and gone, "SIGTERM ends emulate and QEMU", f"exit {rc}")
finally:
    # SIGTERM first: emulate stops its QEMU then. SIGKILL would leave QEMU
    # running (with sleep=off it spins a core) after a failed check.
    if emu.poll() is None:
        emu.send_signal(signal.SIGTERM)
        try:
            emu.wait(timeout=10)
        except subprocess.TimeoutExpired:
            emu.kill()
            emu.wait()
    shutil.rmtree(tmp, ignore_errors=True)

print(f"{passed} passed, {failed} failed")
sys.exit(1 if failed else 0)
