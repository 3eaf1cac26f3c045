#!/usr/bin/python3
"""Runs a board's self-test image in QEMU and its host replay, and requires:

- the image to exit 0 (its own checks passed: no overruns, no recorder
  gaps, limits refused, overruns counted at an impossible rate, ...);
- for every case the host replays: a board line with the same name, equal
  log_hash (bit-identity of the core on the board vs the host build with
  the same sample type: float on qemu-m7, Q31 on qemu-m3), and equal
  frames, ticks and tracking figures (printed by the same code);
- zero overruns and gaps on the board.

It prints the per-tick budget figures (instructions, ADC read to DAC write)
and whether they are within the board's budget, without failing on them.

    check_selftest.py <host_selftest> <selftest.elf> <machine> <float|q31>

Environment: PIEZOLOOP_QEMU_TIMEOUT (seconds, default 60), QEMU_SYSTEM_ARM.
"""
import json
import os
import subprocess
import sys


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


def main():
    if len(sys.argv) != 5:
        print(__doc__)
        return 2
    host_bin, elf, machine, sample = sys.argv[1:]
    if not os.path.isfile(elf):
        print(f"no firmware image {elf}: build the firmware preset first (tools/test does)")
        return 2
    timeout_s = float(os.environ.get("PIEZOLOOP_QEMU_TIMEOUT", "60"))
    qemu = os.environ.get("QEMU_SYSTEM_ARM", "qemu-system-arm")

    host = subprocess.run([host_bin, sample], capture_output=True, text=True, timeout=300)
    print(host.stdout, end="")
    if host.returncode != 0:
        print(f"host replay failed ({host.returncode}): {host.stderr}")
        return 1
    host_cases = {c["name"]: c for c in json_lines(host.stdout) if "name" in c}

    # -icount shift=0: one instruction per virtual ns (deterministic timing);
    # sleep=off: never tie virtual time to the host clock.
    cmd = [qemu, "-M", machine, "-nographic", "-semihosting", "-icount", "shift=0,sleep=off", "-kernel", elf]
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

    def check(ok, what):
        nonlocal passed, failed
        if ok:
            passed += 1
        else:
            failed += 1
            print(f"FAIL: {what}")

    check(board.returncode == 0, f"firmware exit status {board.returncode} (number of failed self-test items)")
    done = [c for c in lines if c.get("selftest") == "done"]
    check(len(done) == 1 and done[0].get("failures") == 0, "self-test summary line with failures 0")
    for c in lines:
        if "check" in c:
            check(c.get("ok") is True, f"board check {c['check']}: {c}")
    check(len(host_cases) > 0, "host replay printed cases")
    for name, h in host_cases.items():
        b = board_cases.get(name)
        if b is None:
            check(False, f"case {name}: no board line")
            continue
        check(b.get("sample") == sample, f"case {name}: board sample {b.get('sample')} != {sample}")
        for key in ("log_hash", "ticks", "frames", "e_max_um", "e_rms_um", "u_max_abs_V"):
            check(b.get(key) == h.get(key), f"case {name}: {key} board {b.get(key)} != host {h.get(key)}")
        check(b.get("overruns") == 0, f"case {name}: {b.get('overruns')} overruns")
        check(b.get("gaps") == 0, f"case {name}: {b.get('gaps')} recorder gaps")

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
    print(f"{passed} passed, {failed} failed")
    return 0 if failed == 0 else 1


if __name__ == "__main__":
    sys.exit(main())
