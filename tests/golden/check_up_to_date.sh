#!/usr/bin/env bash
# The golden files are scipy/numpy output committed beside the scripts that
# make them (tools/ref/). This regenerates every one in a scratch tree (the
# scripts and the shipped stages some of them model) with
# Debian's python3 and requires the committed file to agree with it (same
# structure, numbers within 1e-9 relative: tests/golden/same_json.py says
# why not byte for byte), so a test can never run against reference data its
# script no longer produces.
set -u
src=$(cd "$(dirname "$0")/../.." && pwd)
tmp=$(mktemp -d)
trap 'rm -rf "$tmp"' EXIT
mkdir -p "$tmp/tools/ref" "$tmp/tests/golden" "$tmp/configs"
# Scripts that model a shipped stage read it from configs/stages/.
cp -r "$src/configs/stages" "$tmp/configs/"
passed=0 failed=0
for script in "$src"/tools/ref/*.py; do
    name=$(basename "$script" .py)
    cp "$script" "$tmp/tools/ref/"
    if ! /usr/bin/python3 "$tmp/tools/ref/$name.py"; then
        echo "FAIL $name: script failed"; failed=$((failed + 1)); continue
    fi
    if /usr/bin/python3 "$src/tests/golden/same_json.py" "$src/tests/golden/$name.json" "$tmp/tests/golden/$name.json"; then
        passed=$((passed + 1))
    else
        echo "FAIL $name: tests/golden/$name.json differs from what tools/ref/$name.py makes"
        failed=$((failed + 1))
    fi
done
echo "$passed passed, $failed failed"
[ "$failed" -eq 0 ]
