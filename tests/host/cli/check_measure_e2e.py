#!/usr/bin/python3
"""`piezoloop --device ADDR measure frf | step | loops` against an emulated
board: the Ahmad2020 stage at 10 kHz on qemu-m7 (float core) and
qemu-m3 (Q31 core).

- measure frf, open loop, multisine, --restart-stage: the board's recording
  has the log hash of `measure frf --scenario` with the board's sample type,
  and the same response line for line (so the accuracy check_measure.py
  proves against the exact sampled response holds for the board); nothing
  lost; afterwards the loop is disarmed and the board's groups are as they
  were (get all).
- measure frf, closed loop with the board's controller: S and T at every
  line, S + T = 1.
- measure step, open loop, --restart-stage: the simulator's log hash.
- measure loops, two amplitudes: the first (from rest on both) the
  simulator's exactly; the second, which the board starts after a pause at
  0 V, within 0.5 % of range of the simulator's (its noise samples differ).
- measure step on configs/stages/asymmetric_hysteresis.json (the output
  map) and on configs/stages/drifting_stage.json (sensor offset, gain
  error, mains pickup, creep and drift, all in the emulation profile): the
  simulator's log hash.
- Hostile requests (amplitude beyond the limits, --to-hz above Nyquist,
  --periods 0, NaN, a closed loop without a controller) exit 2 and nothing
  moves: the loop stays disarmed, no excitation tick runs.

Usage: check_measure_e2e.py PIEZOLOOP SERVO_ELF CONFIGS_DIR qemu-m7|qemu-m3
Exit 77 (skipped) without qemu-system-arm or the image."""
import json
import os
import shutil
import subprocess
import sys
import tempfile
import time

from board_checks import Checks, Emulators, skip_without_qemu

exe, image, configs, board = sys.argv[1:5]
skip_without_qemu(image)
# Both boards run the Ahmad2020 stage at its 10 kHz loop: the float core on
# qemu-m7, the Q31 core on qemu-m3 (check_measure.py proves the simulator's
# response of this stage accurate for both sample types).
scenario = os.path.join(configs, "ahmad2020.json")
case, sample = ("dahl_ff_K", "float") if board == "qemu-m7" else ("dahl_ff_K_q31", "q31")
frf = ["--from-hz", "20", "--to-hz", "4000", "--amplitude-v", "1", "--bias-v", "5", "--periods", "4"]
step = ["--step-v", "2", "--bias-v", "3", "--duration-s", "0.02"]
loops = ["--amplitudes-v", "4,8", "--frequency-hz", "20", "--cycles", "2"]
tmp = tempfile.mkdtemp(prefix="check_measure_e2e_")
check = Checks()
emulators = Emulators(exe)


def run(*args):
    return subprocess.run([exe, *args], capture_output=True, text=True, timeout=300)


def load(path):
    with open(path) as f:
        return json.load(f)


try:
    _, d, _ = emulators.start("--board", board, "--scenario", scenario, "--image", image)
    r = run(*d, "set", "--scenario", scenario, "--case", case, "--frequency-hz", "10")
    check(r.returncode == 0, "set --scenario: the case's limits and controller on the board", r.stderr)
    r = run(*d, "set", "recorder", "--json", '{"channels": ["r", "y", "e", "u"], "mode": "continuous"}')
    check(r.returncode == 0, "set recorder: a recorder configuration of the user's", r.stderr)
    groups_before = json.loads(run(*d, "get", "all").stdout)

    def status():
        return json.loads(run(*d, "status").stdout)["status"]

    # Hostile requests first: refused before anything moves.
    ticks_before = status()["excitation"]["ticks"]
    for what, args, text in (
            ("amplitude beyond the limits", ["--from-hz", "100", "--to-hz", "1000", "--amplitude-v", "9",
                                             "--bias-v", "5"], "--amplitude-v"),
            ("--to-hz above Nyquist", ["--from-hz", "100", "--to-hz", "1e6", "--amplitude-v", "1"], "--to-hz"),
            ("--periods 0", ["--from-hz", "100", "--to-hz", "1000", "--amplitude-v", "1", "--periods", "0"],
             "--periods"),
            ("NaN amplitude", ["--from-hz", "100", "--to-hz", "1000", "--amplitude-v", "nan"], "--amplitude-v")):
        r = run(*d, "measure", "frf", *args, "--out", os.path.join(tmp, "x.json"))
        check(r.returncode == 2 and text in r.stderr, f"refused: {what}", r.stderr)
    r = run(*d, "measure", "step", "--step-v", "100", "--out", os.path.join(tmp, "x.json"))
    check(r.returncode == 2 and "--step-v" in r.stderr, "refused: a step beyond the limits", r.stderr)
    st = status()
    check(not st["armed"] and st["excitation"]["ticks"] == ticks_before and st["u_V"] == 0,
          "nothing moved: disarmed, no excitation tick, u = 0 V", json.dumps(st))

    # The frequency response: board = simulator.
    board_json, sim_json = os.path.join(tmp, "board.json"), os.path.join(tmp, "sim.json")
    r = run(*d, "measure", "frf", *frf, "--restart-stage", "--out", board_json)
    check(r.returncode == 0, "measure frf on the board", r.stderr)
    s = run("measure", "frf", "--scenario", scenario, "--sample", sample, *frf, "--out", sim_json)
    check(s.returncode == 0, "measure frf on the simulator", s.stderr)
    b, m = load(board_json), load(sim_json)
    rec = b.get("recording", {})
    check(rec.get("lost_blocks") == 0 and rec.get("recorder_overruns") == 0 and rec.get("tick_overruns") == 0,
          f"{rec.get('frames')} frames recorded, nothing lost", json.dumps(rec))
    check(b["log_hash"] == m["log_hash"], "frf: the board's log hash is the simulator's",
          f"{b['log_hash']} vs {m['log_hash']}")
    check(b["response"] == m["response"] and b["frequency_Hz"] == m["frequency_Hz"],
          f"frf: the same response at all {len(m['frequency_Hz'])} lines")
    st = status()
    check(not st["armed"] and not st["excitation"]["running"], "after frf: disarmed, the excitation ended")
    check(json.loads(run(*d, "get", "all").stdout) == groups_before,
          "after frf: the board's controller and recorder groups are put back")

    # Closed loop: the board's own controller.
    closed_json = os.path.join(tmp, "closed.json")
    r = run(*d, "measure", "frf", *frf[:4], "--amplitude-v", "0.5", "--mode", "closed", "--periods", "2",
            "--out", closed_json)
    if check(r.returncode == 0, "measure frf --mode closed on the board", r.stderr):
        c = load(closed_json)
        worst = max(abs(sv[0] + tv[0] - 1) + abs(sv[1] + tv[1])
                    for sv, tv in zip(c["sensitivity"], c["complementary_sensitivity"]))
        check(len(c["sensitivity"]) == len(c["frequency_Hz"]) and worst < 1e-12,
              "closed loop: S and T at every line, S + T = 1")
    run(*d, "disarm")

    # A step: board = simulator.
    r = run(*d, "measure", "step", *step, "--restart-stage", "--out", board_json)
    s = run("measure", "step", "--scenario", scenario, "--sample", sample, *step, "--out", sim_json)
    ok = r.returncode == 0 and s.returncode == 0
    check(ok and load(board_json)["log_hash"] == load(sim_json)["log_hash"],
          "step: the board's log hash is the simulator's", r.stderr + s.stderr)

    # Loops: each amplitude within 0.05 % of the simulator's hysteresis.
    r = run(*d, "measure", "loops", *loops, "--restart-stage", "--out", os.path.join(tmp, "b.csv"),
            "--json", board_json)
    s = run("measure", "loops", "--scenario", scenario, "--sample", sample, *loops, "--out",
            os.path.join(tmp, "s.csv"), "--json", sim_json)
    if check(r.returncode == 0 and s.returncode == 0, "measure loops on the board and the simulator",
             r.stderr + s.stderr):
        bl, sl = load(board_json)["loops"], load(sim_json)["loops"]
        check(len(bl) == len(sl) == 2 and bl[0] == sl[0],
              "loops: the first amplitude (from rest on both) is the simulator's exactly")
        # The second starts after a pause at 0 V on the board, back to back
        # on the simulator, so its sensor noise samples differ: the
        # hysteresis (one interpolated difference of two noisy readings) is
        # the same within a few noise sigmas of the range.
        diff = abs(bl[1]["hysteresis_pct"] - sl[1]["hysteresis_pct"])
        check(diff < 0.5, f"loops: the second amplitude's hysteresis as the simulator's ({diff:.2e} % apart)")

    # A measurement killed in its excitation (SIGKILL: nothing is put back):
    # the next client's session ends what the killed one started at its
    # Hello, instead of the excitation running on for as long as some client
    # keeps the link alive.
    killed = subprocess.Popen([exe, *d, "measure", "frf", "--from-hz", "1", "--to-hz", "100", "--amplitude-v", "1",
                               "--bias-v", "5", "--periods", "100", "--out", os.path.join(tmp, "killed.json")],
                              stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
    time.sleep(4.0)
    running = killed.poll() is None
    killed.kill()
    killed.wait()
    # The hello asks the tick to stop the excitation; the tick does so on its
    # next run, which on a loaded emulator can come after that session's
    # status reply: ask again for up to 2 s.
    st = status()
    for _ in range(20):
        if not st["excitation"]["running"]:
            break
        time.sleep(0.1)
        st = status()
    check(running and not st["excitation"]["running"] and "client_lost" in json.dumps(st),
          "a killed measurement's excitation ends at the next client's hello (client_lost)", json.dumps(st))
    run(*d, "disarm")

    def step_on_stage(name, step, what):
        """A board on configs/stages/NAME's emulation profile: a step, board = simulator."""
        emulators.stop(emulators.running[0])
        stage = os.path.join(configs, "stages", name + ".json")
        _, d, _ = emulators.start("--board", board, "--scenario", stage, "--image", image)
        r = run(*d, "set", "--scenario", stage, "--case", "open_loop", "--frequency-hz", "10")
        check(r.returncode == 0, "set --scenario: %s's limits on the board" % name, r.stderr)
        r = run(*d, "measure", "step", *step, "--restart-stage", "--out", board_json)
        s = run("measure", "step", "--scenario", stage, "--sample", sample, *step, "--out", sim_json)
        ok = r.returncode == 0 and s.returncode == 0
        check(ok and load(board_json)["log_hash"] == load(sim_json)["log_hash"],
              "step %s: the board's log hash is the simulator's" % what, r.stderr + s.stderr)

    # A stage with every real-stage effect (sensor offset, gain error, mains
    # pickup, creep, drift), long enough (0.25 s) for the mains, the first
    # creep decades and the drift.
    step_on_stage("drifting_stage", ["--step-v", "4", "--bias-v", "3", "--duration-s", "0.25"],
                  "with offset, gain error, mains, creep and drift")
    # A loop that is not a PI model's (the hysteresis's output map): a step
    # up into the map's flattened part.
    step_on_stage("asymmetric_hysteresis", ["--step-v", "5", "--bias-v", "4", "--duration-s", "0.05"],
                  "into the output map's flattened part")
finally:
    emulators.stop_all()
    shutil.rmtree(tmp, ignore_errors=True)

check.exit()
