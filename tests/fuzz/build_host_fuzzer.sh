#!/bin/sh
# Builds the libFuzzer targets of the host's readers with clang, ASan and
# UBSan: the host sources they need compiled together as one translation
# unit (they share nlohmann-json and Eigen, which one unit instantiates once
# instead of once per file), and each target linked with it.
# usage: build_host_fuzzer.sh CLANGXX SOURCE_ROOT OUT_DIR TARGET.cpp... -- HOST_SOURCE...
#        (HOST_SOURCE relative to SOURCE_ROOT/host, e.g. json/json_reader.cpp);
#        each TARGET.cpp becomes OUT_DIR/TARGET.
set -eu
cxx=$1 root=$2 out=$3
shift 3
targets=""
while [ "$1" != "--" ]; do targets="$targets $1"; shift; done
shift
# -O0: the Eigen-heavy host sources compile in half the time of -O1 under
# the sanitizers, which matters more to CI's time than the fuzzers'
# executions per second in their few seconds' run.
# The unit instantiates the Eigen decompositions it uses (host/lti/decompositions.hpp).
flags="-std=c++20 -g1 -O0 -fsanitize=address,undefined -fno-sanitize-recover=undefined -DNDEBUG
       -DPIEZOLOOP_DECOMPOSITIONS_INLINE -I$root/host -I$root/common -isystem /usr/include/eigen3"
mkdir -p "$out"
unit="$out/fuzz_host_sources.cpp"
: > "$unit"
for src in "$@"; do
    echo "#include \"$root/host/$src\"" >> "$unit"
done
$cxx $flags -fsanitize=fuzzer-no-link -c "$unit" -o "$out/fuzz_host_sources.o"
for target in $targets; do
    $cxx $flags -fsanitize=fuzzer "$target" "$out/fuzz_host_sources.o" -o "$out/$(basename "$target" .cpp)"
done
