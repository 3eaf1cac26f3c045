#!/bin/sh
# Runs the libFuzzer target for a bounded time on the committed seed corpus.
# New inputs go to a scratch corpus in the build tree, never into the source.
# usage: run_fuzz.sh <fuzz binary> <seed corpus dir> <scratch dir> <seconds> [max input bytes, 4096]
set -eu
bin=$1 seeds=$2 work=$3 secs=$4 max_len=${5:-4096}
rm -rf "$work"
mkdir -p "$work/corpus" "$work/artifacts"
exec "$bin" -max_total_time="$secs" -timeout=10 -rss_limit_mb=2048 -max_len="$max_len" \
    -print_final_stats=1 -artifact_prefix="$work/artifacts/" "$work/corpus" "$seeds"
