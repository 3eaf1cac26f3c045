#!/usr/bin/env bash
# Runs a firmware image in QEMU and checks its smoke line and exit status.
#
#   run_qemu.sh <elf> <machine> [expected-regex]
#
#   <machine>         qemu-system-arm -M value: mps2-an500 (qemu-m7) or
#                     mps2-an385 (qemu-m3)
#   [expected-regex]  extended regex one UART line must match; default
#                     '^smoke board=<board> ok( |$)' with <board> from the
#                     machine (any board for other machines)
#
# Environment: PIEZOLOOP_QEMU_TIMEOUT (seconds, default 30),
#              QEMU_SYSTEM_ARM (default qemu-system-arm).
#
# -icount shift=0: one virtual nanosecond per instruction, so timing read
# by the firmware is deterministic; sleep=off never ties virtual time to the
# host clock. -semihosting: the firmware leaves QEMU
# with SYS_EXIT, whose status becomes QEMU's exit status.
# Exit status: 0 only if the line appeared and QEMU exited 0.
set -u

if [ $# -lt 2 ] || [ $# -gt 3 ]; then
    echo "usage: $0 <elf> <machine> [expected-regex]" >&2
    exit 2
fi
elf=$1
machine=$2
case "$machine" in
    mps2-an500) board=qemu-m7 ;;
    mps2-an385) board=qemu-m3 ;;
    *) board='[a-z0-9-]+' ;;
esac
pattern=${3:-"^smoke board=${board} ok( |\$)"}
timeout_s=${PIEZOLOOP_QEMU_TIMEOUT:-30}
qemu=${QEMU_SYSTEM_ARM:-qemu-system-arm}

if [ ! -f "$elf" ]; then
    echo "run_qemu: no such image: $elf" >&2
    exit 2
fi

out=$(mktemp)
trap 'rm -f "$out"' EXIT

# stdin from /dev/null: -nographic puts the UART and the monitor on stdio.
timeout --kill-after=5 "$timeout_s" \
    "$qemu" -M "$machine" -nographic -semihosting -icount shift=0,sleep=off -kernel "$elf" \
    </dev/null >"$out" 2>&1
status=$?

cat "$out"

fail=0
if [ $status -eq 124 ] || [ $status -eq 137 ]; then
    echo "run_qemu: FAIL: timed out after ${timeout_s}s" >&2
    fail=1
elif [ $status -ne 0 ]; then
    echo "run_qemu: FAIL: exit status $status (semihosting exit status of the firmware, or QEMU error)" >&2
    fail=1
fi
if ! tr -d '\r' <"$out" | grep -Eq -- "$pattern"; then
    echo "run_qemu: FAIL: no UART line matches '$pattern'" >&2
    fail=1
fi
[ $fail -eq 0 ] && echo "run_qemu: PASS ($machine, $(basename "$elf"))"
exit $fail
