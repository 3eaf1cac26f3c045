#!/usr/bin/python3
"""Hostile input files: every command that reads a model, a scenario, a CSV
or JSON parameters refuses them with exit 2 and a message naming the field
(or the file), quickly and without crashing:

  a model nested 16,000 series deep (design c2d, analyze loop, reduce, sim
  with the model inline in a scenario), a 20,000-coefficient denominator,
  /dev/zero as a model, duplicate keys (model, scenario, set --json), a
  number no double holds (1e309) in a scenario; and a CSV that starts with
  a UTF-8 byte-order mark is read like any other.
Usage: check_hostile_input.py PIEZOLOOP_BINARY CONFIGS_DIR"""
import json
import os
import socket
import stat
import subprocess
import sys
import tempfile

exe, configs = sys.argv[1], os.path.abspath(sys.argv[2])
passed = failed = 0
tmp = tempfile.mkdtemp(prefix="piezoloop-hostile-")


def run(*args):
    env = dict(os.environ)
    env.pop("PIEZOLOOP_DEVICE", None)
    try:
        return subprocess.run([exe, *args], capture_output=True, text=True, env=env, timeout=120)
    except subprocess.TimeoutExpired:
        return subprocess.CompletedProcess(args, -999, "", "timed out after 120 s")


def check(name, ok, detail=""):
    global passed, failed
    if ok:
        passed += 1
    else:
        failed += 1
        print(f"FAIL {name}: {detail}")


def refused(name, args, *needles):
    r = run(*args)
    check(name, r.returncode == 2 and r.stdout == "" and all(n in r.stderr for n in needles),
          f"exit {r.returncode}, missing {[n for n in needles if n not in r.stderr]}, stderr {r.stderr[-300:]!r}")


def write(name, text):
    path = os.path.join(tmp, name)
    with open(path, "w") as f:
        f.write(text)
    return path


deep_text = '{"series":[' * 16000 + '{"num":[1],"den":[1,1]}' + "]}" * 16000
deep = write("deep.json", deep_text)
wide = write("wide.json", json.dumps({"num": [1.0], "den": [1.0] * 20000}))
plant = os.path.join(configs, "models", "ahmad2020_G.json")
controller = os.path.join(configs, "models", "ahmad2020_K.json")

refused("design c2d: model nested 16000 deep", ["design", "c2d", "--model", deep, "--rate-hz", "10000"],
        "deep.json", "nested deeper than")
refused("analyze loop: plant nested 16000 deep", ["analyze", "loop", "--plant", deep, "--controller", controller],
        "nested deeper than")
refused("reduce: model nested 16000 deep", ["reduce", "--model", deep, "--order", "2"], "nested deeper than")
refused("design c2d: 20000 coefficients", ["design", "c2d", "--model", wide, "--rate-hz", "10000"],
        "model.den", "at most 201 coefficients")
refused("reduce: 20000 coefficients", ["reduce", "--model", wide, "--order", "2"], "model.den")
refused("design c2d: /dev/zero", ["design", "c2d", "--model", "/dev/zero", "--rate-hz", "10000"],
        "/dev/zero", "larger than")
dup_model = write("dup.json", '{"num": [1], "den": [1, 1], "den": [1, 2]}')
refused("design c2d: duplicate key", ["design", "c2d", "--model", dup_model, "--rate-hz", "10000"],
        "den", "duplicate key")

# Scenarios: a copy of a shipped one, edited as text.
base = json.load(open(os.path.join(configs, "janaideh2016.json")))
case = base["cases"][0]["name"]


def scenario(name, text):
    path = write(name, text)
    # Model files named in the scenario are relative to it.
    models = os.path.join(tmp, "models")
    if not os.path.exists(models):
        os.symlink(os.path.join(configs, "models"), models)
    return path


good = json.dumps(base)
refused("sim: 1e309 in a scenario", ["sim", "--scenario", scenario("big.json", good.replace(
    '"rate_Hz": ' + json.dumps(base["loop"]["rate_Hz"]), '"rate_Hz": 1e309', 1)), "--case", case],
        "loop.rate_Hz", "out of the range of a double")
refused("sim: duplicate key in a scenario", ["sim", "--scenario", scenario("dupkey.json", good.replace(
    '"loop": {', '"loop": {"rate_Hz": 1, ', 1)), "--case", case], "loop.rate_Hz", "duplicate key")
inline = dict(base)
inline["cases"] = [dict(base["cases"][0])]
deep_inline = good.replace('"cases": [', '"x_deep": ' + deep_text + ', "cases": [', 1)
refused("sim: a model nested 16000 deep inline", ["sim", "--scenario", scenario("deep_inline.json", deep_inline),
                                                 "--case", case], "nested deeper than")

# set --json is checked before any board is contacted.
s = socket.socket()
s.bind(("127.0.0.1", 0))
port = s.getsockname()[1]
s.close()
refused("set --json duplicate key", ["--device", f"tcp:127.0.0.1:{port}", "set", "limits", "--json",
                                     '{"u_max_V": 5, "u_max_V": 6}'], "--json", "u_max_V", "duplicate key")

# emulate --storage takes a regular file (or makes one) and refuses anything
# a save's rename would replace or a read would block on, before the image
# or QEMU is looked at, and leaves it as it was.
no_image = os.path.join(tmp, "no-such-servo.elf")
fifo = os.path.join(tmp, "storage.fifo")
os.mkfifo(fifo)
read_only = write("read_only.bin", "kept")
os.chmod(read_only, 0o444)
for name, path, kind in (("a character device", "/dev/null", "character device"), ("a FIFO", fifo, "FIFO"),
                         ("a directory", tmp, "directory"), ("a read-only file", read_only, "read-only")):
    refused(f"emulate --storage on {name}", ["emulate", "--board", "qemu-m3", "--image", no_image, "--storage", path],
            "--storage", path, kind)
check("emulate --storage leaves a FIFO a FIFO", os.path.exists(fifo) and stat.S_ISFIFO(os.stat(fifo).st_mode))
check("emulate --storage leaves /dev/null a device", stat.S_ISCHR(os.stat("/dev/null").st_mode))
with open(read_only) as f:
    check("emulate --storage leaves a read-only file as it was", f.read() == "kept")
check("emulate --storage makes no .new file", not os.path.exists(read_only + ".new") and not os.path.exists(fifo + ".new"))

# CSV with a byte-order mark (and CRLF line ends), as spreadsheets write it.
rows = "\r\n".join(f"{k * 1e-3:.3f},{(k % 7) - 3},{0.5 * ((k - 1) % 7) - 1.5 if k else 0}" for k in range(200))
bom = os.path.join(tmp, "bom.csv")
with open(bom, "w", encoding="utf-8-sig", newline="") as f:
    f.write("t,u,y\r\n" + rows + "\r\n")
r = run("identify", "rls", "--data", bom, "--na", "1", "--nb", "1")
check("identify rls reads a CSV with a byte-order mark", r.returncode == 0 and '"fit"' in r.stdout,
      f"exit {r.returncode}, stderr {r.stderr[-300:]!r}")


# null where a number (or any value) is required: refused naming the field,
# never read as "absent" (the default): a scenario's sensor noise and seed,
# (a board group's field too: python/tests/test_arguments.py, on a board).
for field in ("sensor.noise_rms", "sensor.seed", "sensor.bandwidth_Hz"):
    doc = json.loads(good)
    doc["plant"]["sensor"][field.split(".")[1]] = None
    refused(f"sim: {field} null", ["sim", "--scenario", scenario(f"null_{field}.json", json.dumps(doc)), "--case",
                                   case, "--amplitude-um", "10"], field, "must not be null")

# Lists of numbers: an empty item is refused naming the option and the item
# (CLI11's delimiter dropped it: "1,,2" ran two loops), as text is.
refused("measure loops: empty amplitude", ["measure", "loops", "--scenario", os.path.join(configs, "ahmad2020.json"),
                                          "--amplitudes-v", "1,,2", "--out", os.path.join(tmp, "l.csv")],
        "--amplitudes-v", "item 2", "empty")
refused("measure loops: trailing comma", ["measure", "loops", "--scenario", os.path.join(configs, "ahmad2020.json"),
                                         "--amplitudes-v", "3,", "--out", os.path.join(tmp, "l.csv")],
        "--amplitudes-v", "item 2", "empty")
# The browser console's options, refused before any board starts.
refused("ui: port 70000", ["ui", "--port", "70000"], "--port")
refused("ui: history 0.5 s", ["ui", "--history-s", "0.5"], "--history-s")
refused("ui: history nan", ["ui", "--history-s", "nan"], "--history-s")
refused("ui: --case without --scenario", ["ui", "--case", "dahl_ff_K"], "--case")
for address in ["999.1.1.1", "example.org", "127.0.0.1:80", ""]:
    refused(f"ui: --bind {address!r}", ["ui", "--scenario", os.path.join(configs, "ahmad2020.json"), "--bind", address],
            "--bind")
refused("pi-inverse: empty weight", ["pi-inverse", "--thresholds", "0,1,2", "--weights", "1,,0.5"], "--weights",
        "item 2")
refused("pi-inverse: text threshold", ["pi-inverse", "--thresholds", "0,one", "--weights", "1,0.5"], "--thresholds",
        "not a number")
refused("identify pi: nan threshold", ["identify", "pi", "--data", bom, "--thresholds", "0.5,nan"], "--thresholds",
        "finite")
r = run("pi-inverse", "--thresholds", "0,1.5", "--weights", "1,0.25")
check("pi-inverse: a clean list is read", r.returncode == 0 and '"weights"' in r.stdout, r.stderr[-300:])

# identify tf: the measured response a fit reads. Every line once (a line
# twice with two responses has no single value to fit), finite, between 0
# and Nyquist; std_db a spread (>= 0 dB) or null (unknown).
rate = 20000.0
freqs = [50.0 * 1.3 ** k for k in range(20)]  # 50 Hz .. 7.3 kHz
resp = []
for fk in freqs:
    g = 2.0 / complex(1.0, fk / 800.0)  # 2 um/V, pole at 800 Hz
    resp.append([g.real, g.imag])
frf = {"frequency_Hz": freqs, "response": resp, "std_db": [0.05] * len(freqs), "excitation": {"rate_Hz": rate}}


def frf_file(name, **changes):
    doc = json.loads(json.dumps(frf))
    for key, (i, v) in changes.items():
        doc[key][i] = v
    return write(name, json.dumps(doc))


r = run("identify", "tf", "--frf", frf_file("frf_ok.json"), "--order", "1/0")
check("identify tf: the clean response fits", r.returncode == 0 and '"model"' in r.stdout, r.stderr[-300:])
refused("identify tf: a line twice, two responses",
        ["identify", "tf", "--frf", frf_file("frf_dup.json", frequency_Hz=(7, freqs[3])), "--order", "1/0"],
        "frequency_Hz[7]", "frequency_Hz[3] again")
refused("identify tf: a line twice within rounding, two responses",
        ["identify", "tf", "--frf", frf_file("frf_near.json", frequency_Hz=(9, freqs[8] * (1 + 3e-13))), "--order",
         "1/0"], "frequency_Hz[9]", "frequency_Hz[8]", "the same line again")
refused("identify tf: negative std_db",
        ["identify", "tf", "--frf", frf_file("frf_neg.json", std_db=(4, -0.2)), "--order", "1/0"],
        "std_db[4]", ">= 0")
refused("identify tf: std_db text",
        ["identify", "tf", "--frf", frf_file("frf_text.json", std_db=(2, "low")), "--order", "1/0"], "std_db[2]")
refused("identify tf: a line above Nyquist",
        ["identify", "tf", "--frf", frf_file("frf_nyq.json", frequency_Hz=(19, 0.6 * rate)), "--order", "1/0"],
        "frequency_Hz[19]", "Nyquist")
refused("identify tf: a negative line",
        ["identify", "tf", "--frf", frf_file("frf_negf.json", frequency_Hz=(0, -50.0)), "--order", "1/0"],
        "frequency_Hz[0]")
r = run("identify", "tf", "--frf", frf_file("frf_null.json", std_db=(5, None)), "--order", "1/0")
check("identify tf: a null std_db (one period) is read", r.returncode == 0, r.stderr[-300:])

# commission --scenario on a 100 Hz loop: its measurements cannot run there;
# the refusal names what the user can change (the scenario's loop), not
# `measure step`'s --duration-s, which commission does not have.
slow = json.load(open(os.path.join(configs, "ahmad2020.json")))
slow["loop"]["rate_Hz"] = 100
slow["experiments"] = []
slow["cases"] = [c for c in slow["cases"] if c["name"] == "open_loop"]
r = run("commission", "--scenario", scenario("slow_loop.json", json.dumps(slow)), "--range-um", "10", "--out",
        os.path.join(tmp, "commission"))
check("commission at 100 Hz names the scenario's loop", r.returncode == 2 and r.stdout == "" and
      "loop.rate_Hz" in r.stderr and "100 Hz loop" in r.stderr and "--duration-s" not in r.stderr,
      f"exit {r.returncode}, stderr {r.stderr[-400:]!r}")

print(f"hostile input: {passed} passed, {failed} failed")
sys.exit(1 if failed else 0)
