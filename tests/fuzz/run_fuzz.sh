#!/bin/sh
# Runs the libFuzzer target for a bounded time on the committed seed corpus.
# New inputs go to a scratch corpus in the build tree, never into the source.
# usage: run_fuzz.sh <fuzz binary> <seed corpus dir> <scratch dir> <seconds>
set -eu
bin=$1 seeds=$2 work=$3 secs=$4
rm -rf "$work"
mkdir -p "$work/corpus" "$work/artifacts"
exec "$bin" -max_total_time="$secs" -timeout=10 -rss_limit_mb=2048 -max_len=4096 \
    -print_final_stats=1 -artifact_prefix="$work/artifacts/" "$work/corpus" "$seeds"
