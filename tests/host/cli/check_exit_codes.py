#!/usr/bin/python3
"""The exit-code policy of every command (README.md, "Exit codes"): 0 ok,
1 other failure, 2 bad input, 3 link or device, 4 lost data (the record
tests in check_device_e2e.py). Then the class "a non-finite number in a
numeric option": every floating-point option of every subcommand, found in
`--help`, refuses nan, inf, -inf and 1e309 with exit 2 and the option's name.
Usage: check_exit_codes.py PIEZOLOOP_BINARY CONFIGS_DIR"""
import json
import os
import re
import socket
import subprocess
import sys
import tempfile

exe, configs = sys.argv[1], sys.argv[2]
passed = failed = 0


def run(*args):
    env = dict(os.environ)
    env.pop("PIEZOLOOP_DEVICE", None)
    return subprocess.run([exe, *args], capture_output=True, text=True, env=env, timeout=120)


def check(name, ok, detail=""):
    global passed, failed
    if ok:
        passed += 1
    else:
        failed += 1
        print(f"FAIL {name}: {detail}")


def expect(name, args, code, *needles):
    r = run(*args)
    check(name, r.returncode == code and all(n in r.stderr for n in needles),
          f"exit {r.returncode} (want {code}), stderr {r.stderr[-400:]!r}")
    return r


def closed_port():
    s = socket.socket()
    s.bind(("127.0.0.1", 0))
    port = s.getsockname()[1]
    s.close()
    return port


scenario = os.path.join(configs, "ahmad2020.json")
tmp = tempfile.mkdtemp(prefix="piezoloop-exit-")
unwritable = os.path.join(tmp, "no-such-dir", "x")

# 0: ok, help included.
expect("help", ["--help"], 0)
expect("subcommand help", ["identify", "rls", "--help"], 0)
# 2: option errors of the parser (CLI11's own codes are 104-109).
expect("value out of range", ["identify", "rls", "--ts", "0", "--data", "x.csv"], 2, "--ts")
expect("ui: a takeover answer time out of range", ["ui", "--seat-answer-s", "0"], 2, "--seat-answer-s")
expect("scan: a retrace speed out of range", ["scan", "--scenario", os.path.join(configs, "stages", "xy_flexure.json"),
                                              "--retrace-speed", "17", "--out", os.path.join(tmp, "scan_refused")], 2,
       "--retrace-speed")
expect("missing required option", ["sim"], 2, "--scenario")
expect("not a number", ["demo", "--frequency-hz", "ten"], 2, "--frequency-hz")
expect("unknown option", ["demo", "--bogus"], 2, "--bogus")
expect("unknown subcommand", ["bogus"], 2)
expect("no subcommand", [], 2)
expect("missing input file (sim)", ["sim", "--scenario", "/nonexistent.json", "--case", "x"], 2, "--scenario")
expect("missing input file (design)", ["design", "c2d", "--model", "/nonexistent.json", "--rate-hz", "1000"], 2,
       "cannot open")
expect("bad value (sim)", ["sim", "--scenario", scenario, "--case", "no_such_case"], 2, "no such case")
# A hysteresis output map that is not increasing: refused naming its entry.
with open(os.path.join(configs, "stages", "asymmetric_hysteresis.json")) as f:
    bad_map = json.load(f)
bad_map["plant"]["hysteresis"]["output_map"]["weights"] = [-0.25, -0.9]
bad_map_file = os.path.join(tmp, "bad_map.json")
with open(bad_map_file, "w") as f:
    json.dump(bad_map, f)
expect("bad output map (sim)", ["sim", "--scenario", bad_map_file, "--case", "open_loop", "--frequency-hz", "1",
                                "--amplitude-um", "5"], 2, "plant.hysteresis.output_map.weights[1]")
# A stage of coupled axes (configs/stages/xyz_flexure.json) in a command that
# runs one axis: refused, naming the command, before anything runs or is
# written.
xyz = os.path.join(configs, "stages", "xyz_flexure.json")
multi = "runs single-axis stages only so far"
# sim runs them with one axis driven: which one is to be named.
sim_xyz = ["sim", "--scenario", xyz, "--case", "open_loop", "--frequency-hz", "10", "--amplitude-um", "5"]
expect("sim: a stage of axes without --axis", sim_xyz, 2, "--axis: a stage of axes x, y, z: choose one")
expect("sim: an unknown --axis", sim_xyz + ["--axis", "w"], 2, "--axis: must be one of the axes x, y, z (got \"w\")")
expect("sim: --hold-um of an unknown axis", sim_xyz + ["--axis", "x", "--hold-um", "w=3"], 2, "--hold-um: must be one of")
expect("sim: --hold-um beyond the full scale", sim_xyz + ["--axis", "x", "--hold-um", "y=500"], 2, "--hold-um y: must be in")
expect("sim: --start-together on one axis", ["sim", "--scenario", scenario, "--case", "no_such_case", "--start-together"], 2,
       "--start-together: the scenario's stage has one axis")
expect("sim: --axis on one axis", ["sim", "--scenario", scenario, "--case", "no_such_case", "--axis", "x"], 2, "--axis:")
for name, args in [
        ("measure frf without --mimo", ["measure", "frf", "--scenario", xyz, "--from-hz", "10", "--to-hz", "1000", "--amplitude-v", "0.1",
                     "--out", os.path.join(tmp, "xyz_frf.json")]),
        ("measure", ["measure", "step", "--scenario", xyz, "--step-v", "1", "--out", os.path.join(tmp, "xyz_step.json")]),
        ("measure", ["measure", "loops", "--scenario", xyz, "--amplitudes-v", "1,2", "--out", os.path.join(tmp, "xyz.csv")])]:
    expect(f"multi-axis scenario ({' '.join(args[:2])})", args, 2, f"multi-axis scenario: {name} {multi}")
# emulate runs a stage of axes on a board that carries them (qemu-m3: two).
expect("emulate: three axes on qemu-m3", ["emulate", "--scenario", xyz, "--board", "qemu-m3"], 2,
       "--scenario: xyz_flexure has 3 axes, qemu-m3 runs at most 2 (3 axes: --board qemu-m7)")
# --axis picks a board's axis; on the simulator it is refused, naming it.
expect("measure frf --axis on the simulator", ["measure", "frf", "--scenario", scenario, "--axis", "y", "--from-hz", "10",
       "--to-hz", "100", "--amplitude-v", "0.1", "--out", os.path.join(tmp, "axis_frf.json")], 2,
       "--axis: only on a board (--device)")
expect("measure step --axis on the simulator", ["measure", "step", "--scenario", scenario, "--axis", "y", "--step-v", "1",
       "--out", os.path.join(tmp, "axis_step.json")], 2, "--axis: only on a board (--device)")
expect("commission --axis on the simulator", ["commission", "--scenario", scenario, "--axis", "y", "--range-um", "10",
       "--out", os.path.join(tmp, "axis_commission")], 2, "--axis: a board's axis")
# commission on a stage of axes commissions them all (--axes), and says so.
expect("multi-axis scenario (commission without --axes)",
       ["commission", "--scenario", xyz, "--range-um", "10", "--out", os.path.join(tmp, "xyz_commission")], 2,
       "--axes: the scenario's stage has coupled axes; commission them with --axes x,y,z")
# measure frf --mimo: what it cannot measure, refused before anything runs.
mimo = ["measure", "frf", "--mimo", "--from-hz", "20", "--to-hz", "2000", "--out", os.path.join(tmp, "xyz_mimo.csv")]
for why, args, needle in [
        ("one axis", ["--scenario", scenario, "--amplitude-v", "0.1"], "--mimo:"),
        ("board", ["--amplitude-v", "0.1"], "--mimo:"),
        ("closed loop", ["--scenario", xyz, "--amplitude-v", "0.1", "--mode", "closed"], "--mode:"),
        ("beyond the hard limits", ["--scenario", xyz, "--amplitude-v", "6", "--bias-v", "5"], "--amplitude-v:"),
        ("no output matrix file", ["--scenario", xyz, "--amplitude-v", "0.1", "--bias-v", "5", "--output-matrix",
                                   "/nonexistent.json"], "--output-matrix:"),
        ("output matrix without --mimo", [], None)]:
    if needle is None:
        expect(f"measure frf --mimo: {why}", ["measure", "frf", "--scenario", scenario, "--from-hz", "20", "--to-hz",
                                              "2000", "--amplitude-v", "0.1", "--output-matrix", "m.json", "--out",
                                              os.path.join(tmp, "xyz_single.json")], 2, "--output-matrix:")
    else:
        expect(f"measure frf --mimo: {why}", mimo + args, 2, needle)
# --output-matrix files that are not an n x n matrix of the stage's axes.
for why, text, needle in [
        ("not JSON", "{", "is not JSON"),
        ("no output_matrix", '{"matrix": [[1]]}', 'has no "output_matrix"'),
        ("a row too short", '{"output_matrix": [[1, 0, 0], [0, 1], [0, 0, 1]]}', "output_matrix[1]"),
        ("not a number", '{"output_matrix": [[1, 0, 0], [0, "1", 0], [0, 0, 1]]}', "output_matrix[1][1]"),
        ("2 x 2 on 3 axes", '{"output_matrix": [[1, 0], [0, 1]]}', "must be 3 x 3"),
        ("singular", '{"output_matrix": [[1, 1, 0], [1, 1, 0], [0, 0, 1]]}', "output_matrix")]:
    path = os.path.join(tmp, "matrix.json")
    with open(path, "w") as f:
        f.write(text)
    expect(f"measure frf --mimo --output-matrix: {why}",
           mimo + ["--scenario", xyz, "--amplitude-v", "0.1", "--bias-v", "5", "--output-matrix", path], 2,
           "--output-matrix", needle)
check("multi-axis scenario: nothing written", not any(n.startswith("xyz") for n in os.listdir(tmp)), str(os.listdir(tmp)))
expect("missing input file (reproduce)", ["reproduce", "ahmad2020", "--out", tmp, "--configs", "/nonexistent"], 2)
# A malformed --device is bad input, not a link failure (3 is for a board that
# cannot be reached at a well-formed address).
for address in ("carrier-pigeon:7", "tcp:localhost", "tcp:127.0.0.1:99999", "serial:/dev/null@fast"):
    expect(f"malformed --device {address}", ["--device", address, "status"], 2, "--device")
# 1: an output that cannot be written.
cases = run("sim", "--scenario", scenario, "--list").stdout
case = re.search(r'"name":\s*"([^"]+)"', cases)
check("sim --list names a case", case is not None, cases[:200])
if case:
    expect("sim --out unwritable", ["sim", "--scenario", scenario, "--case", case.group(1), "--amplitude-um", "10",
                                    "--out", unwritable + ".csv"], 1, "cannot write")
expect("reproduce --out unwritable", ["reproduce", "ahmad2020", "--configs", configs, "--out", "/proc/piezoloop-no",
                                      "--no-plots", "--no-fidelity"], 1)
# 3: link or device.
refused = f"tcp:127.0.0.1:{closed_port()}"
expect("connection refused", ["--device", refused, "status"], 3, "connection refused")
expect("record, connection refused", ["--device", refused, "record", "--duration-s", "0.1"], 3)

# Every floating-point option of every subcommand refuses non-finite values.
def subcommands(path):
    text = run(*path, "--help").stdout
    m = re.search(r"^Subcommands:\n((?:  .*\n?)*)", text, re.M)
    names = re.findall(r"^  (\S+)", m.group(1), re.M) if m else []
    return text, names


def walk(path):
    text, names = subcommands(path)
    yield path, text
    for n in names:
        yield from walk([*path, n])


float_options = []
for path, text in walk([]):
    for opt in re.findall(r"^\s+(?:-\w,)?(--[\w-]+)(?:,-\w)? FLOAT", text, re.M):
        float_options.append((path, opt))
check("float options found", len(float_options) >= 40, f"only {len(float_options)}: {float_options}")
for path, opt in float_options:
    for bad in ("nan", "inf", "-inf", "1e309"):
        r = run(*path, opt, bad)
        check(f"{' '.join(path)} {opt} {bad}", r.returncode == 2 and opt in r.stderr,
              f"exit {r.returncode}, stderr {r.stderr[-300:]!r}")
print(f"exit codes: {passed} passed, {failed} failed ({len(float_options)} floating-point options)")
sys.exit(1 if failed else 0)
