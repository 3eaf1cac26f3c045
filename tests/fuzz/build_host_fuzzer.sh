#!/bin/sh
# Builds a libFuzzer target of the host's readers with clang, ASan and UBSan:
# the target's source and the host sources it needs, each compiled once into
# a shared object directory (the three reader targets share most of them).
# usage: build_host_fuzzer.sh CLANGXX SOURCE_ROOT OBJ_DIR OUT_BINARY TARGET.cpp HOST_SOURCE...
#        (HOST_SOURCE relative to SOURCE_ROOT/host, e.g. json/json_reader.cpp)
set -eu
cxx=$1 root=$2 obj=$3 out=$4 target=$5
shift 5
# -O0: the Eigen-heavy host sources compile in half the time of -O1 under
# the sanitizers (sos.cpp: 8.6 s vs 16.1 s), which matters more to CI's time
# than the fuzzer's executions per second in its 8 s run.
# Each file instantiates the Eigen decompositions it uses (host/lti/decompositions.hpp).
flags="-std=c++20 -g1 -O0 -fsanitize=address,undefined -fno-sanitize-recover=undefined -DNDEBUG
       -DPIEZOLOOP_DECOMPOSITIONS_INLINE -I$root/host -I$root/common -isystem /usr/include/eigen3"
mkdir -p "$obj"
objects=""
for src in "$@"; do
    o="$obj/$(echo "$src" | tr / _).o"
    # Recompiled when the source is newer (its headers are the tree's; a CI
    # build starts from scratch).
    if [ ! -f "$o" ] || [ "$root/host/$src" -nt "$o" ]; then
        $cxx $flags -fsanitize=fuzzer-no-link -c "$root/host/$src" -o "$o"
    fi
    objects="$objects $o"
done
$cxx $flags -fsanitize=fuzzer "$target" $objects -o "$out"
