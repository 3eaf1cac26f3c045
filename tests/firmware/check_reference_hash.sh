#!/usr/bin/env bash
# Bit-identity of the core across platforms: the reference closed loop run on
# an emulated board must give the same log hash as the host build of the same
# code with the same sample type.
#
#   check_reference_hash.sh <host_reference_hash> <elf> <machine> <float|q31>
set -u
host_bin=$1 elf=$2 machine=$3 sample=$4
here=$(dirname "$0")

if [ ! -f "$elf" ]; then
    echo "no firmware image $elf: build the firmware preset first (tools/test does)" >&2
    exit 2
fi
host_line=$("$host_bin" "$sample") || { echo "host run failed: $host_line"; exit 1; }
board_out=$("$here/run_qemu.sh" "$elf" "$machine" "^reference board=[a-z0-9-]+ sample=${sample} ") \
    || { echo "board run failed:"; echo "$board_out"; exit 1; }
board_line=$(echo "$board_out" | grep '^reference board=')
hash() { echo "$1" | sed -n 's/.*log_hash=\(0x[0-9a-f]*\).*/\1/p'; }
echo "host:  $host_line"
echo "board: $board_line"
if [ -n "$(hash "$host_line")" ] && [ "$(hash "$host_line")" = "$(hash "$board_line")" ]; then
    echo "1 passed, 0 failed"
    exit 0
fi
echo "log hashes differ"
echo "0 passed, 1 failed"
exit 1
