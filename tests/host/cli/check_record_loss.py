#!/usr/bin/python3
"""A record that ends early keeps what arrived (README.md, "Exit codes"):
against an emulated board, a long `record --out F` is cut short three ways,

  the board dies (SIGKILL of QEMU),
  the board freezes (SIGSTOP of QEMU; the log stalls after --stall-s),
  the user presses Ctrl-C (SIGINT to `piezoloop record`),

and each time the command exits 4 (lost data), as a `measure` or
`commission` interrupted by Ctrl-C does, its summary says
"complete": false and why, and F holds the frames that arrived under a
"# incomplete: ..." first line, replacing an older file at F (never left
looking current), with no temporary file left behind. After Ctrl-C the
board's recorder is stopped. A record that completes has no such line.

Usage: check_record_loss.py PIEZOLOOP SERVO_ELF CONFIGS_DIR [qemu-m7|qemu-m3]
Exit 77 (skipped) without qemu-system-arm or the image."""
import json
import os
import shutil
import signal
import subprocess
import sys
import tempfile
import time

exe, image, configs = sys.argv[1], sys.argv[2], sys.argv[3]
board = sys.argv[4] if len(sys.argv) > 4 else "qemu-m7"
scenario = os.path.join(configs, "ahmad2020.json" if board == "qemu-m7" else "janaideh2016.json")
if not os.path.exists(image) or shutil.which(os.environ.get("QEMU_SYSTEM_ARM", "qemu-system-arm")) is None:
    print(f"skipped: no QEMU or no image {image}")
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


def start_board():
    emu = subprocess.Popen([exe, "emulate", "--board", board, "--scenario", scenario, "--image", image],
                           stdout=subprocess.PIPE, stderr=subprocess.DEVNULL, text=True)
    info = json.loads(emu.stdout.readline())
    return emu, info


def stop_board(emu, info):
    try:
        os.kill(info["pid"], signal.SIGCONT)
    except ProcessLookupError:
        pass
    if emu.poll() is None:
        emu.send_signal(signal.SIGTERM)
        try:
            emu.wait(timeout=20)
        except subprocess.TimeoutExpired:
            emu.kill()
            emu.wait()


def long_record(dev, out, *extra):
    """A 60 s record of r, y, e, u, started in the background; returns once frames flow."""
    p = subprocess.Popen([exe, "--device", dev, "record", "--duration-s", "60", "--out", out, *extra],
                         stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
    time.sleep(2.0)
    return p


def check_cut(what, p, out, cause):
    try:
        stdout, stderr = p.communicate(timeout=60)
    except subprocess.TimeoutExpired:
        p.kill()
        stdout, stderr = p.communicate()
    j = json.loads(stdout) if stdout.strip().startswith("{") else {}
    check(p.returncode == 4, f"{what}: exit 4 (lost data)", f"exit {p.returncode}, stderr {stderr[-300:]!r}")
    check(j.get("complete") is False and cause in j.get("incomplete", "") and j.get("frames", 0) > 0,
          f"{what}: the summary says incomplete ({cause}) with the frames that arrived",
          json.dumps({k: j.get(k) for k in ("complete", "incomplete", "frames", "expected_frames")}))
    check("record incomplete" in stderr, f"{what}: stderr says the record is incomplete", stderr[-300:])
    lines = open(out).read().splitlines() if os.path.exists(out) else []
    check(len(lines) > 2 and lines[0].startswith("# incomplete:") and lines[1].startswith("t_s,") and
          len(lines) - 2 == j.get("frames"),
          f"{what}: {os.path.basename(out)} holds the {j.get('frames')} frames that arrived under '# incomplete'",
          f"{len(lines)} lines, first {lines[:2]}")
    leftovers = [f for f in os.listdir(os.path.dirname(out)) if ".partial-" in f]
    check(not leftovers, f"{what}: no temporary file left", str(leftovers))


tmp = tempfile.mkdtemp(prefix="check_record_loss_")
try:
    # A complete record has no marker.
    emu, info = start_board()
    dev = info["device"]
    out = os.path.join(tmp, "ok.csv")
    r = subprocess.run([exe, "--device", dev, "record", "--duration-s", "0.05", "--out", out], capture_output=True,
                       text=True, timeout=120)
    j = json.loads(r.stdout) if r.returncode == 0 else {}
    first = open(out).readline() if os.path.exists(out) else ""
    check(r.returncode == 0 and j.get("complete") is True and first.startswith("t_s,"),
          "a complete record: exit 0, complete, no marker", r.stderr + first)

    # Ctrl-C: the record stops, the board's recorder too.
    out = os.path.join(tmp, "sigint.csv")
    with open(out, "w") as f:
        f.write("t_s,r_um\n0,1\n")  # an older file: must not survive looking current
    p = long_record(dev, out)
    p.send_signal(signal.SIGINT)
    check_cut("Ctrl-C", p, out, "interrupted")
    st = subprocess.run([exe, "--device", dev, "status"], capture_output=True, text=True, timeout=60)
    state = json.loads(st.stdout)["status"]["recorder_state"] if st.returncode == 0 else None
    check(state in ("idle", "done"), "Ctrl-C: the board's recorder is stopped", f"recorder_state {state}")

    # Ctrl-C during a measurement or a commissioning on the board: the same
    # policy as record's, exit 4 (an interrupted run whose data is
    # incomplete), the board left with no excitation running and disarmed.
    out_dir = os.path.join(tmp, "commission")
    subprocess.run([exe, "--device", dev, "set", "--scenario", scenario, "--case", "open_loop"], capture_output=True,
                   text=True, timeout=60, check=True)  # the limits the measurements need
    for what, args in (("measure frf", ["measure", "frf", "--from-hz", "1", "--to-hz", "50", "--amplitude-v", "0.2",
                                        "--periods", "40", "--out", os.path.join(tmp, "frf.json")]),
                       ("measure loops", ["measure", "loops", "--amplitudes-v", "1,2", "--frequency-hz", "0.2",
                                          "--cycles", "3", "--out", os.path.join(tmp, "loops.csv")]),
                       ("commission", ["commission", "--range-um", "10", "--out", out_dir])):
        p = subprocess.Popen([exe, "--device", dev, *args], stdout=subprocess.PIPE, stderr=subprocess.PIPE,
                             text=True)
        time.sleep(3.0)
        p.send_signal(signal.SIGINT)
        try:
            _, stderr = p.communicate(timeout=60)
        except subprocess.TimeoutExpired:
            p.kill()
            _, stderr = p.communicate()
        check(p.returncode == 4 and "interrupted" in stderr, f"Ctrl-C in {what}: exit 4, says interrupted",
              f"exit {p.returncode}, stderr {stderr[-300:]!r}")
        st = subprocess.run([exe, "--device", dev, "status"], capture_output=True, text=True, timeout=60)
        s = json.loads(st.stdout)["status"] if st.returncode == 0 else {}
        check(s.get("excitation", {}).get("running") is False and s.get("armed") is False,
              f"Ctrl-C in {what}: no excitation running, disarmed", json.dumps(s)[:300])

    # The board freezes: the log stalls.
    out = os.path.join(tmp, "frozen.csv")
    p = long_record(dev, out, "--stall-s", "1")
    os.kill(info["pid"], signal.SIGSTOP)
    check_cut("board frozen", p, out, "stalled")
    stop_board(emu, info)

    # The board dies.
    emu, info = start_board()
    out = os.path.join(tmp, "killed.csv")
    p = long_record(info["device"], out)
    os.kill(info["pid"], signal.SIGKILL)
    check_cut("board killed", p, out, "link failed")
    stop_board(emu, info)
finally:
    shutil.rmtree(tmp, ignore_errors=True)

print(f"{passed} passed, {failed} failed")
sys.exit(1 if failed else 0)
