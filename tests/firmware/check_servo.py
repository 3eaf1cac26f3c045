#!/usr/bin/python3
"""The servo image's minimal link service, driven through QEMU's console.

Waits for the ready line (QEMU's CMSDK UART accepts and drops bytes while
the firmware has not yet enabled its receiver), then sends
h s a w z z s d z s q  and requires, in order: ready, help, status
(running, disarmed), armed, wave ok, two waits of >= 1000 ticks each while
the wave runs armed (the stage moves: y changes), status, disarmed, a wait
after which the output has ramped to 0 V, status, bye, and exit status 0;
no overruns anywhere. Tick counts depend on when the bytes arrive (host
timing), so only their differences are checked.

    check_servo.py <servo.elf> <machine>
"""
import json
import os
import subprocess
import sys
import threading

COMMANDS = "h s a w z z s d z s q"
EXPECTED = ["ready", "help", "status", "armed", "wave", "waited", "waited", "status", "disarmed", "waited",
            "status", "bye"]


def main():
    if len(sys.argv) != 3:
        print(__doc__)
        return 2
    elf, machine = sys.argv[1:]
    if not os.path.isfile(elf):
        print(f"no firmware image {elf}: build the firmware preset first")
        return 2
    qemu = os.environ.get("QEMU_SYSTEM_ARM", "qemu-system-arm")
    cmd = [qemu, "-M", machine, "-nographic", "-semihosting", "-icount", "shift=0,sleep=off", "-kernel", elf]
    timeout_s = float(os.environ.get("PIEZOLOOP_QEMU_TIMEOUT", "60"))
    proc = subprocess.Popen(cmd, stdin=subprocess.PIPE, stdout=subprocess.PIPE, stderr=subprocess.STDOUT,
                            text=True)
    timer = threading.Timer(timeout_s, proc.kill)
    timer.start()
    lines = []
    for line in proc.stdout:  # until the firmware says it is listening
        lines.append(line)
        if '"reply":"ready"' in line:
            break
    try:
        proc.stdin.write(COMMANDS)
        proc.stdin.close()
    except BrokenPipeError:
        pass
    lines.extend(proc.stdout)
    returncode = proc.wait()
    timed_out = not timer.is_alive()
    timer.cancel()
    out = "".join(lines)
    print(out, end="")
    if timed_out:
        print(f"FAIL: QEMU killed after {timeout_s} s")
        return 1
    replies = [json.loads(l) for l in out.replace("\r", "").splitlines() if l.startswith("{")]
    failed = []

    def check(ok, what):
        if not ok:
            failed.append(what)
            print(f"FAIL: {what}")

    check(returncode == 0, f"exit status {returncode}")
    names = [r.get("reply") for r in replies]
    check(names == EXPECTED, f"replies {names} != {EXPECTED}")
    if names == EXPECTED:
        r = replies
        check(r[0]["ok"] is True and r[0]["rate_Hz"] == 100000, "ready ok at 100 kHz")
        check(r[2]["running"] and r[2]["armed"] is False, "starts running, disarmed")
        check(r[3]["armed"] is True, "armed")
        check(r[4]["ok"] is True, "wave started")
        check(r[5]["ticks"] - r[3]["ticks"] >= 1000 and r[6]["ticks"] - r[5]["ticks"] >= 1000,
              "each wait lasts >= 1000 ticks")
        check(r[5]["wave"] and r[5]["y_um"] != r[6]["y_um"], "the stage follows the wave")
        check(r[8]["armed"] is False, "disarmed")
        check(r[9]["u_V"] == 0.0, "disarmed output ramps to 0 V within 10 ms (slew 2e5 V/s)")
        for x in replies:
            if "overruns" in x:
                check(x["overruns"] == 0, f"no overruns: {x}")
    print(f"{0 if failed else 1} passed, {len(failed)} failed")
    return 1 if failed else 0


if __name__ == "__main__":
    sys.exit(main())
