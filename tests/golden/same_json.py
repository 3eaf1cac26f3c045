#!/usr/bin/python3
"""Compares two golden JSON files: the same structure, keys, strings,
booleans and integers, and every other number equal to within 1e-6 of its
scale (the larger magnitude of the two values, or of the list they stand
in), except the location of a flat maximum.
Why not byte for byte: numpy and LAPACK pick their SIMD kernels by the
processor at run time and sum in different orders, so the same script gives
slightly different results on different machines. Seen between two x86-64
machines: up to 4e-7 relative in peak frequencies found by a search and in
balanced-truncation poles, 3e-9 in stiff step responses, 1e-11 elsewhere.
The peak frequency of an H-infinity norm whose maximum is flat at DC
(`peak_w` beside a `w_scale`) moved by 7e-9 rad/s; it is compared as the
tests compare it, within 1e-4 of w_scale.
Usage: same_json.py COMMITTED REGENERATED (exit 0 if they agree)"""
import json
import sys

REL = 1e-6


def is_number(x):
    return isinstance(x, (int, float)) and not isinstance(x, bool)


def differ(a, b, path, scale=0.0):
    if isinstance(a, dict) and isinstance(b, dict):
        if sorted(a) != sorted(b):
            return f"{path}: keys differ"
        for k in a:
            if k.startswith("peak_w") and is_number(a.get("w_scale")) and is_number(a[k]) and is_number(b[k]):
                if abs(a[k] - b[k]) > 1e-4 * a["w_scale"] + REL * max(abs(a[k]), abs(b[k])):
                    return f"{path}.{k}: {a[k]!r} vs {b[k]!r}"
                continue
            d = differ(a[k], b[k], f"{path}.{k}")
            if d:
                return d
        return None
    if isinstance(a, list) and isinstance(b, list):
        if len(a) != len(b):
            return f"{path}: {len(a)} vs {len(b)} elements"
        s = max([abs(x) for x in a + b if is_number(x)], default=0.0)
        for i, (x, y) in enumerate(zip(a, b)):
            d = differ(x, y, f"{path}[{i}]", s)
            if d:
                return d
        return None
    if isinstance(a, float) or isinstance(b, float):
        if not (is_number(a) and is_number(b)):
            return f"{path}: {a!r} vs {b!r}"
        if a != a and b != b:
            return None  # both NaN
        if abs(a - b) <= REL * max(abs(a), abs(b), scale):
            return None
        return f"{path}: {a!r} vs {b!r}"
    return None if a == b and type(a) == type(b) else f"{path}: {a!r} vs {b!r}"


with open(sys.argv[1]) as f:
    committed = json.load(f)
with open(sys.argv[2]) as f:
    regenerated = json.load(f)
d = differ(committed, regenerated, "")
if d:
    print(d)
sys.exit(1 if d else 0)
