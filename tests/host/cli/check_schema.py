#!/usr/bin/python3
"""`piezoloop schema`: the parameter tree as JSON Schema, checked by an
independent validator (Debian's python3-jsonschema, draft 2020-12): the
schema is itself valid, the parameter file of a scenario case (`sim
--board-case`'s groups as `get all` prints them) validates, and values out of
the declared ranges, unknown fields and wrong enum names do not.
Usage: check_schema.py PIEZOLOOP_BINARY"""
import copy
import json
import subprocess
import sys

import jsonschema  # python3-jsonschema, installed by tools/setup

exe = sys.argv[1]
passed = failed = 0


def check(ok, what, detail=""):
    global passed, failed
    if ok:
        passed += 1
        print("ok   " + what)
    else:
        failed += 1
        print("FAIL " + what + (f": {detail}" if detail else ""))


r = subprocess.run([exe, "schema"], capture_output=True, text=True, timeout=60)
schema = json.loads(r.stdout)
check(r.returncode == 0 and schema["$schema"] == "https://json-schema.org/draft/2020-12/schema", "schema printed")
V = jsonschema.Draft202012Validator
try:
    V.check_schema(schema)
    check(True, "the schema is valid JSON Schema 2020-12")
except jsonschema.SchemaError as e:
    check(False, "the schema is valid JSON Schema 2020-12", str(e))
v = V(schema)


def defaults(node):
    """A document made of every field's declared default (a field without
    one, the limits' slew, which the board needs set, is left out)."""
    if node.get("type") == "object":
        return {k: defaults(p) for k, p in node["properties"].items() if "default" in p or p.get("type") == "object"}
    return copy.deepcopy(node["default"])


doc = defaults(schema)
errors = list(v.iter_errors(doc))
check(not errors, "every declared default lies in its declared range", "; ".join(e.message for e in errors))
check(set(doc) == {"feedforward", "feedback", "rc", "limits", "trajectory", "recorder", "link", "input_matrix",
                   "output_matrix"}, "the nine groups", str(sorted(doc)))
per_axis = {k for k, p in schema["properties"].items() if p.get("perAxis")}
check(per_axis == {"feedforward", "feedback", "rc", "limits", "trajectory"},
      "the axis's groups are perAxis, the board's not", str(sorted(per_axis)))
check("default" not in schema["properties"]["limits"]["properties"]["slew_V_per_s"],
      "no default where the declared one is out of range (the limits' slew)")

# A realistic set: the Janaideh2016 case's groups (what `set --scenario`
# sends), as the board's JSON reader reads them.
good = copy.deepcopy(doc)
good["limits"].update({"u_min_V": -10.0, "u_max_V": 10.0, "slew_V_per_s": 2e5})
good["feedback"].update({"kind": "sos", "sections": [{"b0": 0.5, "b1": 0.1, "b2": 0.0, "a1": -1.9, "a2": 0.9025}]})
good["recorder"].update({"channels": ["r", "y", "e", "u"], "decimation": 1})
check(v.is_valid(good), "a controller set validates")

for what, path, value in [
    ("a saturation trip beyond 1000 s", ("limits", "saturation_trip_s"), 2000.0),
    ("a zero slew limit (exclusive minimum)", ("limits", "slew_V_per_s"), 0.0),
    ("an unknown feedback kind", ("feedback", "kind"), "lqr"),
    ("a negative integral gain", ("feedback", "pid", "ki_per_s"), -1.0),
    ("a five-section cascade", ("feedback", "sections"), [{"b0": 1.0, "b1": 0.0, "b2": 0.0, "a1": 0.0, "a2": 0.0}] * 5),
    ("a signal that does not exist", ("recorder", "channels"), ["r", "x"]),
    ("an unknown field", ("limits", "u_max"), 5.0),
    ("a client timeout of two hours", ("link", "client_timeout_s"), 7200.0),
]:
    bad = copy.deepcopy(good)
    node = bad
    for k in path[:-1]:
        node = node[k]
    node[path[-1]] = value
    check(not v.is_valid(bad), f"refused: {what}")

print(f"{passed} passed, {failed} failed")
sys.exit(1 if failed else 0)
