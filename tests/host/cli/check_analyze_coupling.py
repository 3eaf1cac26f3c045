#!/usr/bin/python3
"""End to end: `piezoloop analyze coupling` on MIMO FRF files holding scipy's
exact response of the 2x2 and 3x3 systems of tests/golden/mimo_frf_ref.json
(tools/ref/mimo_frf_ref.py), written here in the documented format
(host/measure/mimo_frf_file.hpp; the C++ writer's round trip is
tests/host/measure/test_mimo_frf_file.cpp): the coupling figures, the static
gain, its condition, the output matrix and the coupling after it against
numpy's (tolerances of test_coupling.cpp and test_static_decoupling.cpp).
Then bad input: exit 2 naming the line and field, nothing on stdout.
Usage: check_analyze_coupling.py PIEZOLOOP_BINARY GOLDEN_DIR
"""
import json
import os
import subprocess
import sys
import tempfile

exe, golden = sys.argv[1], sys.argv[2]
tmp = tempfile.mkdtemp()
passed = failed = 0
ref = json.load(open(os.path.join(golden, "mimo_frf_ref.json")))


def check(ok, what):
    global passed, failed
    if ok:
        passed += 1
    else:
        failed += 1
        print("FAIL", what)


def columns(n_in, n_out):
    return ",".join(["f_Hz"] + ["G%d%d_%s" % (i + 1, j + 1, p) for i in range(n_out) for j in range(n_in)
                                for p in ("re", "im", "std")])


def write(name, n_in, n_out, f_hz, matrices, header_in=None, cols=None, rate=10000):
    path = os.path.join(tmp, name)
    with open(path, "w") as f:
        f.write("# piezoloop mimo-frf 1\n# inputs=%d outputs=%d rate_Hz=%r periods=10\n"
                % (header_in or n_in, n_out, rate))
        f.write((cols or columns(n_in, n_out)) + "\n")
        for fr, m in zip(f_hz, matrices):
            row = [repr(fr)]
            for i in range(n_out):
                for j in range(n_in):
                    row += [repr(m[i][j].real), repr(m[i][j].imag), "1e-6"]
            f.write(",".join(row) + "\n")
    return path


def case_matrices(c):
    n = c["n"]
    return [[[complex(c["response_re"][k][i][j], c["response_im"][k][i][j]) for j in range(n)] for i in range(n)]
            for k in range(len(c["frequency_Hz"]))]


def run(*args):
    return subprocess.run([exe, "analyze", "coupling", *args], capture_output=True, text=True)


for c in ref["cases"]:
    n = c["n"]
    path = write("g%d.csv" % n, n, n, c["frequency_Hz"], case_matrices(c))
    r = run(path)
    check(r.returncode == 0, "%s: run: %d %s" % (c["name"], r.returncode, r.stderr))
    if r.returncode != 0:
        continue
    out = json.loads(r.stdout)
    check(out["axes"] == n and out["lines"] == 200, "%s: axes, lines" % c["name"])
    check(out["low_frequency_lines_Hz"] == c["frequency_Hz"][:3], "%s: low-frequency lines" % c["name"])
    for got, want in zip(out["coupling"], c["coupling"]):
        name = "y%d<-u%d" % (want["output"] + 1, want["input"] + 1)
        check(got["pair"] == name, "pair name %s" % got["pair"])
        check(abs(got["low_frequency_db"] - want["low_frequency_db"]) < 1e-9, "%s low %r" % (name, got))
        check(abs(got["max_db"] - want["max_db"]) < 1e-9 and got["max_Hz"] == want["max_Hz"], "%s max %r" % (name, got))
    for got, want in zip(out["after_lines"], c["after"]):
        check(abs(got["low_frequency_db"] - want["low_frequency_db"]) < 1e-6, "after low %r %r" % (got, want))
        check(abs(got["max_db"] - want["max_db"]) < 1e-9 and got["max_Hz"] == want["max_Hz"], "after max %r" % got)
    check(abs(out["static_gain_condition_1"] - c["condition_1"]) < 1e-12 * c["condition_1"], "condition")
    for got_row, want_row in zip(out["output_matrix"], c["output_matrix"]):
        check(all(abs(a - b) < 1e-12 for a, b in zip(got_row, want_row)), "output matrix %r" % got_row)
    for got_row, want_row in zip(out["static_gain"], c["static_gain"]):
        check(all(abs(a - b) < 1e-12 for a, b in zip(got_row, want_row)), "static gain %r" % got_row)
    check(len(out["after_static_db"]) == n * (n - 1) and
          all(p["db"] is None or p["db"] <= -100 for p in out["after_static_db"]), "after static %r" % out["after_static_db"])

# --below-hz: the lines at or below it.
c2 = ref["cases"][0]
g2 = os.path.join(tmp, "g2.csv")
r = run(g2, "--below-hz", "50")
check(r.returncode == 0 and json.loads(r.stdout)["low_frequency_lines_Hz"] == [10.0, 20.0, 30.0, 40.0, 50.0],
      "--below-hz 50: %s" % r.stderr)


def refused(args, needle, what):
    r = run(*args)
    check(r.returncode == 2 and needle in r.stderr and r.stdout == "",
          "%s: exit %d, stderr %r" % (what, r.returncode, r.stderr))


refused([os.path.join(tmp, "missing.csv")], "cannot read", "missing file")
refused([g2, "--below-hz", "5"], "--below-hz: must be >= the lowest line, 10 Hz", "below the lowest line")
refused([g2, "--below-hz", "0"], "--below-hz: must be > 0 Hz", "below-hz 0")
m2 = case_matrices(c2)
refused([write("mismatch.csv", 2, 2, c2["frequency_Hz"], m2, header_in=3)], "line 3: column", "n mismatch")
rect = [[[1, 0.01, 0.02], [0.03, 1, 0.01]] for _ in range(4)]
refused([write("rect.csv", 3, 2, [1.0, 2.0, 3.0, 4.0], rect)], "outputs: coupling needs as many outputs as inputs",
        "2 outputs, 3 inputs")
ill = [[[1.0, 0.999], [0.999, 1.0]] for _ in range(4)]
refused([write("ill.csv", 2, 2, [1.0, 2.0, 3.0, 4.0], ill)], "G0: ill-conditioned, 1-norm condition 1999 > 1000",
        "ill-conditioned G0")
bad = write("bad.csv", 2, 2, c2["frequency_Hz"][:5], m2[:5])
with open(bad) as f:
    lines = f.read().split("\n")
cells = lines[5].split(",")
cells[5] = "oops"
lines[5] = ",".join(cells)
with open(bad, "w") as f:
    f.write("\n".join(lines))
refused([bad], "line 6: G12_im: must be a finite number", "malformed value")

print("%d passed, %d failed" % (passed, failed))
sys.exit(1 if failed else 0)
