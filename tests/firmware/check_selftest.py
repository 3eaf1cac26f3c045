#!/usr/bin/python3
"""Runs a board's self-test image in QEMU and its host replay, and requires:

- the image to exit 0 (its own checks passed: no overruns, no recorder
  gaps, limits refused, overruns counted at an impossible rate, ...);
- for every case the host replays: a board line with the same name, equal
  log_hash (bit-identity of the core on the board vs the host build with
  the same sample type: float on qemu-m7, Q31 on qemu-m3), and equal
  frames, ticks and tracking figures (printed by the same code);
- zero overruns and gaps on the board.

With --piezoloop and --configs it also runs the scenario cases (SCENARIO_CASES
below, the one list of them): `piezoloop sim ... --duration-s 0.2
--board-case FILE` writes each run as a board case
(common/piezoloop/board_case.hpp), QEMU's generic loader puts the files into
the board's RAM slots, and for each the board must print a line named
"<scenario>/<case>" with
- log_hash equal to the simulator's (bit-identity of the whole run: stage,
  controller, reference; qemu-m7 against the float sim, qemu-m3 against
  `--sample q31`), and equal to the host replay's, as every other field;
- ticks as the simulator ran them, no overruns, no gaps;
- e_max_um and e_rms_um (over the simulator's window, the last reference
  period) within TRACKING_TOL_UM of the simulator's figures.

It prints the per-tick budget figures (instructions, ADC read to DAC write)
and requires every case the board ran to be within the board's budget: the
worst tick's figure (`insn_per_tick_max`, or `cycles_per_tick_max` on
hardware) at most the `budget` the board printed, and the board's own
`within_budget` true. --budget N checks against N instead when N is lower
(a tighter budget, never a looser one). --expect-over-budget CASE tests the check on a real
report: the run is judged as always, then passes only if it failed on the
budget of CASE (among others) and on nothing but budgets (with --budget,
on a board within its own budget).

    check_selftest.py <host_selftest> <selftest.elf> <machine> <float|q31>
                      [--piezoloop EXE --configs DIR] [--budget N]
                      [--expect-over-budget CASE] [--axes-budgets]
    check_selftest.py --self-test

--axes-budgets also judges the multi-axis runs (lines with "axes") on
their ADC-to-DAC budget and their whole-tick budget (tick_budget,
within_tick_budget); without it their hashes are checked but not their
budgets.

--self-test runs the budget check on made-up board lines (within, over by
the worst tick, over by the board's flag, figures missing, a lowered
budget) and fails unless it passes and fails each as it should.

Environment: PIEZOLOOP_QEMU_TIMEOUT (seconds, default 60), QEMU_SYSTEM_ARM.
"""
import json
import os
import subprocess
import sys
import tempfile

# The scenario cases the self-test runs, 0.2 s each:
#   (scenario, case: the source's full controller, the same on both cores,
#    reference: what the scenario's tracking experiment uses)
# ahmad2020: Dahl feedforward + K(s), 10 kHz: 2000 ticks. On qemu-m3 the
#   Q31 core runs the Dahl model in software float and K(s) with its
#   high-gain last section (common/piezoloop/biquad.hpp).
# shan2012: pi_rc_inv, the inverse in series after the controller
#   (FeedforwardKind::kPiSeries) with RC. 1 kHz: RC N = 100 fits the boards'
#   delay line (2048).
SCENARIO_CASES = [
    ("ahmad2020", "dahl_ff_K",
     ["--trajectory", "triangle", "--frequency-hz", "10", "--amplitude-um", "12"]),
    ("janaideh2016", "ff_fb",
     ["--trajectory", "sine", "--frequency-hz", "10", "--amplitude-um", "40"]),
    ("shan2012", "pi_rc_inv",
     ["--trajectory", "triangle", "--frequency-hz", "1000", "--amplitude-um", "10"]),
]
SCENARIO_DURATION_S = "0.2"
BOARD_CASE_ADDRESS = 0x003FE000  # common/piezoloop/board_case.hpp: kBoardCaseAddress
BOARD_CASE_SLOT_BYTES = 2048     # kBoardCaseSlotBytes (3 slots)
# The board prints e_max_um / e_rms_um rounded to 4 decimals (0.5e-4 um) and
# forms e = r - y in the core's sample type before converting it to um,
# where the simulator takes the difference of r and y already converted to
# float um (in double): at most an ulp of a 64 um full scale (7.6e-6 um) per
# sample apart. 1e-4 um covers both with margin; the hashes are exact.
TRACKING_TOL_UM = 1e-4


def json_lines(text):
    out = []
    for line in text.replace("\r", "").splitlines():
        line = line.strip()
        if line.startswith("{"):
            try:
                out.append(json.loads(line))
            except json.JSONDecodeError:
                print(f"unparsable line: {line}")
                out.append({"unparsable": line})
    return out


def budget_failures(board_cases, budget_override=None, axes_budgets=False):
    """The cases over their ADC-read-to-DAC-write budget: [message]. A case
    passes only if its worst tick is at most the budget (the board's, or
    budget_override when that is lower) and the board says within_budget.
    The multi-axis runs (lines with "axes") are judged only with
    axes_budgets, and then on their whole-tick budget too (tick_budget,
    within_tick_budget)."""
    out = []
    for name, b in board_cases.items():
        if "axes" in b:
            if not axes_budgets:
                continue
            unit = "insn" if "tick_insn_max" in b else "cycles"
            worst, budget = b.get("tick_" + unit + "_max"), b.get("tick_budget")
            if not isinstance(worst, int) or not isinstance(budget, int) or budget <= 0:
                out.append(f"case {name}: no whole-tick budget figures (tick_{unit}_max {worst}, tick_budget {budget})")
            elif worst > budget or b.get("within_tick_budget") is not True:
                out.append(f"case {name} on {b.get('board')}: {worst} {unit} per whole tick (worst) over the "
                           f"whole-tick budget of {budget} (within_tick_budget {b.get('within_tick_budget')})")
        unit = "insn" if "insn_per_tick_max" in b else "cycles"
        worst = b.get(unit + "_per_tick_max")
        budget = b.get("budget")
        if not isinstance(worst, int) or not isinstance(budget, int) or budget <= 0:
            out.append(f"case {name}: no budget figures ({unit}_per_tick_max {worst}, budget {budget})")
            continue
        if budget_override is not None and budget_override < budget:
            budget = budget_override
        if worst > budget:
            out.append(f"case {name} on {b.get('board')}: {worst} {unit} per tick (worst, ADC read to DAC write) "
                       f"over the budget of {budget}")
        if b.get("within_budget") is not True:
            out.append(f"case {name} on {b.get('board')}: the board reports within_budget "
                       f"{b.get('within_budget')}")
    return out


def self_test():
    """The budget check against made-up board lines: each must pass or fail
    as stated, else this returns 1."""
    def line(worst, budget=300, within=True, unit="insn"):
        return {"board": "qemu-m7", "name": "x", unit + "_per_tick_max": worst, "budget": budget,
                "within_budget": within}
    cases = [
        ("within (299 of 300)", {"x": line(299)}, None, True),
        ("at the budget (300 of 300)", {"x": line(300)}, None, True),
        ("worst tick over (302 of 300), flag true", {"x": line(302)}, None, False),
        ("flag false, figure within", {"x": line(250, within=False)}, None, False),
        ("flag missing", {"x": {k: v for k, v in line(250).items() if k != "within_budget"}}, None, False),
        ("figures missing", {"x": {"board": "qemu-m7", "name": "x"}}, None, False),
        ("hardware cycles over (801 of 800)", {"x": line(801, 800, unit="cycles")}, None, False),
        ("budget lowered to 250, worst 286", {"x": line(286)}, 250, False),
        ("budget raised to 400 is ignored, worst 302", {"x": line(302)}, 400, False),
        ("one of two cases over", {"a": line(200), "b": line(301)}, None, False),
    ]

    def axes(worst, tick_worst, within=True, within_tick=True):
        return {**line(worst, 600, within), "axes": 3, "tick_insn_max": tick_worst, "tick_budget": 1200,
                "within_tick_budget": within_tick}
    cases += [
        ("axes run within both", {"x": axes(590, 1190)}, "axes", True),
        ("axes run, whole tick over (1201 of 1200)", {"x": axes(590, 1201)}, "axes", False),
        ("axes run, whole-tick flag false", {"x": axes(590, 1100, within_tick=False)}, "axes", False),
        ("axes run, ADC to DAC over (601 of 600)", {"x": axes(601, 1100)}, "axes", False),
        ("axes run, whole-tick budget missing", {"x": {**axes(590, 1100), "tick_budget": None}}, "axes", False),
        ("axes run over, not judged without --axes-budgets", {"x": axes(900, 2000)}, None, True),
    ]
    bad = 0
    for what, board_cases, override, should_pass in cases:
        if override == "axes":
            msgs = budget_failures(board_cases, None, axes_budgets=True)
        else:
            msgs = budget_failures(board_cases, override)
        ok = (not msgs) == should_pass
        bad += 0 if ok else 1
        print(f"{'ok' if ok else 'WRONG'}: {what}: {'passes' if not msgs else 'fails: ' + '; '.join(msgs)}")
    print(f"{len(cases) - bad} passed, {bad} failed")
    return 0 if bad == 0 else 1


def make_board_cases(piezoloop, configs, sample, tmpdir):
    """Runs the simulator for each scenario case; returns [(name, file, sim json)]."""
    out = []
    for i, (scenario, case, reference) in enumerate(SCENARIO_CASES):
        path = os.path.join(tmpdir, f"case{i}.bin")
        cmd = [piezoloop, "sim", "--scenario", os.path.join(configs, scenario + ".json"), "--case", case,
               "--sample", sample, *reference, "--duration-s", SCENARIO_DURATION_S, "--board-case", path]
        print("$ " + " ".join(cmd))
        r = subprocess.run(cmd, capture_output=True, text=True, timeout=600)
        if r.stderr:
            print(r.stderr, end="")
        if r.returncode != 0:
            raise RuntimeError(f"piezoloop sim failed ({r.returncode}) for {scenario}/{case}")
        out.append((f"{scenario}/{case}", path, json.loads(r.stdout)))
    return out


def main():
    args = sys.argv[1:]
    if args == ["--self-test"]:
        return self_test()
    piezoloop = configs = budget_override = expect_over = None
    axes_budgets = "--axes-budgets" in args
    args = [a for a in args if a != "--axes-budgets"]
    while len(args) > 4 and args[-2] in ("--piezoloop", "--configs", "--budget", "--expect-over-budget"):
        if args[-2] == "--expect-over-budget":
            expect_over = args[-1]
        elif args[-2] == "--piezoloop":
            piezoloop = args[-1]
        elif args[-2] == "--configs":
            configs = args[-1]
        else:
            try:
                budget_override = int(args[-1])
            except ValueError:
                budget_override = 0
            if budget_override <= 0:
                print(f"--budget must be a positive integer (instructions or cycles), got {args[-1]}")
                return 2
        args = args[:-2]
    if len(args) != 4 or (piezoloop is None) != (configs is None):
        print(__doc__)
        return 2
    host_bin, elf, machine, sample = args
    if not os.path.isfile(elf):
        print(f"no firmware image {elf}: build the firmware preset first (tools/test does)")
        return 2
    timeout_s = float(os.environ.get("PIEZOLOOP_QEMU_TIMEOUT", "60"))
    qemu = os.environ.get("QEMU_SYSTEM_ARM", "qemu-system-arm")

    tmpdir = tempfile.TemporaryDirectory(prefix="check_selftest_")
    scenario = make_board_cases(piezoloop, configs, sample, tmpdir.name) if piezoloop else []
    if len(scenario) > 3:
        print("FAIL: more scenario cases than the board's 3 slots")
        return 1

    host = subprocess.run([host_bin, sample, *[f for _, f, _ in scenario]], capture_output=True, text=True,
                          timeout=300)
    print(host.stdout, end="")
    if host.returncode != 0:
        print(f"host replay failed ({host.returncode}): {host.stderr}")
        return 1
    host_cases = {c["name"]: c for c in json_lines(host.stdout) if "name" in c}

    # -icount shift=0: one instruction per virtual ns (deterministic timing);
    # sleep=off: never tie virtual time to the host clock.
    cmd = [qemu, "-M", machine, "-nographic", "-semihosting", "-icount", "shift=0,sleep=off", "-kernel", elf]
    for i, (_, path, _) in enumerate(scenario):
        cmd += ["-device", f"loader,file={path},addr=0x{BOARD_CASE_ADDRESS + i * BOARD_CASE_SLOT_BYTES:x}"]
    try:
        board = subprocess.run(cmd, stdin=subprocess.DEVNULL, capture_output=True, text=True, timeout=timeout_s)
    except subprocess.TimeoutExpired as e:
        print((e.stdout or b"").decode(errors="replace") if isinstance(e.stdout, bytes) else (e.stdout or ""))
        print(f"FAIL: QEMU timed out after {timeout_s} s")
        return 1
    print(board.stdout, end="")
    if board.stderr:
        print(board.stderr, end="")
    lines = json_lines(board.stdout)
    board_cases = {c["name"]: c for c in lines if "name" in c}

    passed, failed = 0, 0
    failures = []

    def check(ok, what):
        nonlocal passed, failed
        if ok:
            passed += 1
        else:
            failed += 1
            failures.append(what)
            print(f"FAIL: {what}")

    check(board.returncode == 0, f"firmware exit status {board.returncode} (number of failed self-test items)")
    done = [c for c in lines if c.get("selftest") == "done"]
    check(len(done) == 1 and done[0].get("failures") == 0, "self-test summary line with failures 0")
    for c in lines:
        if "check" in c:
            check(c.get("ok") is True, f"board check {c['check']}: {c}")
        if "error" in c:
            check(False, f"board error line: {c}")
    if scenario and len(done) == 1:
        check(done[0].get("scenario_cases") == len(scenario),
              f"board ran {done[0].get('scenario_cases')} scenario cases, {len(scenario)} loaded")
    check(len(host_cases) > 0, "host replay printed cases")
    for name, h in host_cases.items():
        b = board_cases.get(name)
        if b is None:
            check(False, f"case {name}: no board line")
            continue
        check(b.get("sample") == sample, f"case {name}: board sample {b.get('sample')} != {sample}")
        # Every field the host prints but its name: the multi-axis runs add
        # per-axis hashes and tracking figures (log_hash_<i>, ...).
        for key in h:
            if key != "board":
                check(b.get(key) == h.get(key), f"case {name}: {key} board {b.get(key)} != host {h.get(key)}")
        check(b.get("overruns") == 0, f"case {name}: {b.get('overruns')} overruns")
        check(b.get("gaps") == 0, f"case {name}: {b.get('gaps')} recorder gaps")

    for name, _, sim in scenario:
        b = board_cases.get(name)
        if b is None:
            check(False, f"scenario case {name}: no board line")
            continue
        check(b.get("log_hash") == "0x" + sim["log_hash"],
              f"scenario case {name}: log_hash board {b.get('log_hash')} != sim 0x{sim['log_hash']}")
        check(b.get("ticks") == sim["ticks"] and b.get("frames") == sim["ticks"],
              f"scenario case {name}: ticks/frames board {b.get('ticks')}/{b.get('frames')} != sim {sim['ticks']}")
        check(b.get("loop_rate_Hz") == sim["loop_rate_Hz"],
              f"scenario case {name}: loop rate board {b.get('loop_rate_Hz')} != sim {sim['loop_rate_Hz']}")
        for key in ("e_max_um", "e_rms_um"):
            bv = b.get(key)
            check(isinstance(bv, (int, float)) and abs(bv - sim[key]) <= TRACKING_TOL_UM,
                  f"scenario case {name}: {key} board {bv} vs sim {sim[key]} (tolerance {TRACKING_TOL_UM} um)")
        print(f"  {name}: log_hash board {b.get('log_hash')} sim 0x{sim['log_hash']}; e_max {b.get('e_max_um')} um "
              f"(sim {sim['e_max_um']:.6f}), e_rms {b.get('e_rms_um')} um (sim {sim['e_rms_um']:.6f}), "
              f"{b.get('ticks')} ticks at {b.get('loop_rate_Hz')} Hz")

    print("budget (controller tick, ADC read to DAC write, instructions under -icount shift=0):")
    for name, b in board_cases.items():
        unit = "insn" if "insn_per_tick_max" in b else "cycles"
        print(f"  {b['board']} {name}: {unit} per tick min {b.get(unit + '_per_tick_min')} "
              f"mean {b.get(unit + '_per_tick_mean')} max {b.get(unit + '_per_tick_max')} "
              f"(+-{b.get(unit + '_resolution')}); budget {b.get('budget')}: "
              f"{'within' if b.get('within_budget') else 'OVER'}; "
              f"whole controller tick mean {b.get('tick_' + unit + '_mean')} max {b.get('tick_' + unit + '_max')}; "
              f"reconfigure tick max {b.get('reconfigure_' + unit + '_max')}; "
              f"plant model (apart) mean {b.get('plant_' + unit + '_per_tick_mean')}")
    for name, b in board_cases.items():
        if "axes" in b:
            unit = "insn" if "insn_per_tick_max" in b else "cycles"
            print(f"  {b['board']} {name}: {b['axes']} axes at {b.get('loop_rate_Hz')} Hz: ADC->DAC max "
                  f"{b.get(unit + '_per_tick_max')} (budget {b.get('budget')}), whole tick max "
                  f"{b.get('tick_' + unit + '_max')} (budget {b.get('tick_budget')}), per axis mean "
                  f"{b.get(unit + '_per_axis_mean')} / {b.get('tick_' + unit + '_per_axis_mean')}"
                  f"{'' if axes_budgets else ' (budgets judged with --axes-budgets)'}")
    over = budget_failures(board_cases, budget_override, axes_budgets)
    check(len(board_cases) > 0, "board printed cases with budget figures")
    for msg in over:
        check(False, "budget: " + msg)
    if board_cases and not over:
        passed += 1
    print(f"{passed} passed, {failed} failed")
    if expect_over is not None:
        # The run above, judged the other way round: it must have failed on
        # the budget of expect_over and on nothing else.
        others = [f for f in failures if not f.startswith("budget: ")]
        named = any(f.startswith(f"budget: case {expect_over} ") for f in failures)
        print(f"expected: the budget check fails for {expect_over} and nothing else fails: "
              f"{'so it did' if named and not others else 'it did not'}")
        return 0 if named and not others else 1
    return 0 if failed == 0 else 1


if __name__ == "__main__":
    sys.exit(main())
