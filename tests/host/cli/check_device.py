#!/usr/bin/python3
"""The device subcommands' argument and connection errors, without a board:
each must exit non-zero with a message that says what is wrong and what is
accepted (2: bad input, 3: link error), before touching any device where the
input alone is wrong; `devices` lists USB boards (none here) and says how to
start an emulated one.
Usage: check_device.py PIEZOLOOP_BINARY"""
import json
import os
import socket
import subprocess
import sys

exe = sys.argv[1]
passed = failed = 0


def closed_port():
    """A loopback port that is bound but not listening: connections are refused."""
    s = socket.socket()
    s.bind(("127.0.0.1", 0))
    port = s.getsockname()[1]
    s.close()
    return port


def run(args, env=None):
    e = dict(os.environ)
    e.pop("PIEZOLOOP_DEVICE", None)
    if env:
        e.update(env)
    return subprocess.run([exe, *args], capture_output=True, text=True, env=e, timeout=60)


def expect(name, args, code, *needles, env=None):
    global passed, failed
    r = run(args, env)
    ok = (r.returncode == code if code is not None else r.returncode != 0) and all(n in r.stderr for n in needles)
    if ok:
        passed += 1
    else:
        failed += 1
        print(f"FAIL {name}: exit {r.returncode} (want {code}), stderr {r.stderr!r}, missing "
              f"{[n for n in needles if n not in r.stderr]}")


refused = f"tcp:127.0.0.1:{closed_port()}"
# No board given.
for sub in (["status"], ["get", "limits"], ["arm"], ["disarm"], ["clear-trip"],
            ["record", "--duration-s", "0.1"], ["wave", "--amplitude-um", "5"]):
    expect(f"{sub[0]} without --device", sub, 2, "--device ADDR before the subcommand", "piezoloop devices")
# PIEZOLOOP_DEVICE is the default of --device.
expect("PIEZOLOOP_DEVICE used", ["status"], 3, refused + ": connection refused", env={"PIEZOLOOP_DEVICE": refused})
# Malformed addresses are bad input (exit 2) and name the accepted forms.
for addr in ("bogus", "tcp:localhost", "tcp:localhost:70000", "usb:", "serial:", "serial:/dev/null@fast"):
    expect(f"address {addr!r}", ["--device", addr, "status"], 2, "accepted forms: tcp:HOST:PORT", "usb:SERIAL",
           "serial:PATH[@BAUD]")
expect("connection refused", ["--device", refused, "status"], 3, f"{refused}: connection refused",
       "piezoloop emulate")
expect("serial path missing", ["--device", "serial:/nonexistent/ttyX", "status"], 3,
       "serial:/nonexistent/ttyX@115200: cannot open")
expect("serial not a tty", ["--device", "serial:/dev/null", "status"], 3, "not a serial device")
# Input errors found before connecting (the refused address proves it: exit 2, not 3).
d = ["--device", refused]
expect("get unknown group", [*d, "get", "gains"], 2, "unknown parameter group 'gains'", "limits", "all")
expect("set without --json", [*d, "set", "limits"], 2, "set GROUP --json")
expect("set --scenario without --case", [*d, "set", "--scenario", "/dev/null"], 2, "--scenario needs --case")
expect("set --case without --scenario", [*d, "set", "limits", "--json", "{}", "--case", "x"], 2,
       "--case needs --scenario")
expect("set bad JSON", [*d, "set", "limits", "--json", "{u_max_V: 1"], 2, "--json")
expect("set JSON neither text nor file", [*d, "set", "limits", "--json", "/nonexistent.json"], 2,
       "neither JSON text nor a readable file")
expect("record unknown signal", [*d, "record", "--signals", "r,q", "--duration-s", "1"], 2, "unknown signal 'q'",
       "u_rc")
expect("record repeated signal", [*d, "record", "--signals", "r,r", "--duration-s", "1"], 2, "r twice")
expect("record restart without start", [*d, "record", "--restart-stage", "--duration-s", "1"], 2,
       "--restart-stage: only with --start-wave")
expect("record every axis without start", [*d, "record", "--every-axis", "--duration-s", "1"], 2,
       "--every-axis: only with --start-wave")
expect("record plot without u", [*d, "record", "--signals", "r,y", "--plot", "x.png", "--duration-s", "1"], 2,
       "--plot: needs the signals r, y and u")
expect("record without duration", [*d, "record"], None, "--duration-s")
expect("record trajectory without amplitude", [*d, "record", "--trajectory", "sine", "--duration-s", "1"], 2,
       "--amplitude-um")
expect("record unknown waveform", [*d, "record", "--trajectory", "saw", "--duration-s", "1"], None, "--trajectory")
expect("stream without source", [*d, "stream"], 2, "either --file or a generated wave")
expect("stream wave without duration", [*d, "stream", "--amplitude-um", "5"], 2, "--duration-s")
# emulate: a missing image says how to build one.
expect("emulate missing image", ["emulate", "--image", "/nonexistent/servo.elf"], 2, "--image: no such file")
expect("emulate no firmware dir", ["emulate", "--board", "qemu-m3"], 2, "no firmware image at /nonexistent/fw-qemu-m3",
       "cmake --preset fw-qemu-m3", env={"PIEZOLOOP_FIRMWARE_DIR": "/nonexistent"})
expect("emulate unknown board", ["emulate", "--board", "qemu-m4"], None, "--board")
expect("emulate --case without --scenario", ["emulate", "--case", "x"], 2, "--case needs --scenario")

# devices: JSON with the USB list and the way to an emulated board.
r = run(["devices"])
try:
    j = json.loads(r.stdout)
    ok = r.returncode == 0 and isinstance(j["usb"], list) and "piezoloop emulate" in j["emulated"]
except (ValueError, KeyError):
    ok = False
if ok:
    passed += 1
else:
    failed += 1
    print(f"FAIL devices: exit {r.returncode}: {r.stdout!r} {r.stderr!r}")

print(f"{passed} passed, {failed} failed")
sys.exit(1 if failed else 0)
