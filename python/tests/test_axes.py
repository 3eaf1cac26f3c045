"""Stages of coupled axes (configs/stages/xy_flexure.json, xyz_flexure.json)
from Python against the command line: piezoloop.sim with axis= and its hash
and figures equal to `piezoloop sim --axis`, measure_frf(mimo=True) equal
to the CSV `piezoloop measure frf --mimo` writes, analyze_coupling equal to
`piezoloop analyze coupling` on it; the refusals name the argument. And a
board of axes (qemu-m3) recorded with axis= equal to the command line's
simulator."""
import csv
import json
import math
import os

import numpy as np
import pytest

import piezoloop
from conftest import CONFIGS, cli, need_qemu

XY = os.path.join(CONFIGS, "stages", "xy_flexure.json")
XYZ = os.path.join(CONFIGS, "stages", "xyz_flexure.json")

# A short run: two periods of 20 Hz after the approach.
SIM = dict(frequency_hz=20.0, amplitude_um=80.0, midpoint_um=50.0)
SIM_CLI = ["--frequency-hz", "20", "--amplitude-um", "80", "--midpoint-um", "50"]


@pytest.mark.parametrize("case", ["open_loop", "pi_notch_decoupled"])
def test_sim_axes_equal_cli(case):
    run = piezoloop.sim(XYZ, case, axis="x", hold_um={"y": 50, "z": 7.5}, **SIM)
    args = ["sim", "--scenario", XYZ, "--case", case, "--axis", "x", "--hold-um", "y=50", "--hold-um", "z=7.5"]
    args += SIM_CLI
    assert run.log_hash == cli(*args, "--hash").strip()
    # The CLI's JSON of a closed loop checks each controller's realisation
    # (its notes; seconds): compared on the open loop only.
    if case == "open_loop":
        ref = json.loads(cli(*args))
        for k in ("axis", "axes", "cross_motion_pct", "e_max_um", "e_rms_um", "ticks", "window_start_tick",
                  "approach_ticks", "output_matrix", "log_hash", "trajectory"):
            assert run.metrics[k] == ref[k], k
    # The cross motion again from the signals: the held axes' true position
    # over the window, peak to peak, as % of the driven axis's reference
    # range (the summary's definition, in the float samples it is made of).
    s, m = run.signals, run.metrics
    assert len(s["tick"]) == m["ticks"] and set(m["cross_motion_pct"]) == {"y", "z"}
    w = s["tick"] >= m["window_start_tick"]
    r_x = s["r_x_um"][w].astype(np.float32)
    span = float(r_x.max()) - float(r_x.min())
    for a in ("y", "z"):
        p = s[f"p_{a}_um"][w].astype(np.float32)
        assert 100.0 * (float(p.max()) - float(p.min())) / span == m["cross_motion_pct"][a], a


def test_sim_axes_hold_one_value_for_all():
    run = piezoloop.sim(XY, "open_loop", axis="y", hold_um=20, **SIM)
    h = cli("sim", "--scenario", XY, "--case", "open_loop", "--axis", "y", "--hold-um", "20", *SIM_CLI, "--hash")
    assert run.log_hash == h.strip() and run.metrics["axes"]["x"]["hold_um"] == 20.0


def test_sim_axes_refusals():
    with pytest.raises(ValueError, match=r"axis: a stage of axes x, y, z: choose one"):
        piezoloop.sim(XYZ, "open_loop", **SIM)
    with pytest.raises(ValueError, match=r"axis: must be one of the axes x, y, z \(got \"w\"\)"):
        piezoloop.sim(XYZ, "open_loop", axis="w", **SIM)
    with pytest.raises(ValueError, match=r"hold-um: must be one of the axes x, y"):
        piezoloop.sim(XY, "open_loop", axis="x", hold_um={"q": 1}, **SIM)
    with pytest.raises(ValueError, match=r"hold-um y: must be in \[-"):
        piezoloop.sim(XY, "open_loop", axis="x", hold_um={"y": 1e6}, **SIM)
    with pytest.raises(TypeError, match="hold_um"):
        piezoloop.sim(XY, "open_loop", axis="x", hold_um={"y": "50"}, **SIM)
    shan = os.path.join(CONFIGS, "shan2012.json")
    with pytest.raises(ValueError, match="axis: the scenario's stage has one axis"):
        piezoloop.sim(shan, "pi", axis="x", amplitude_um=1, frequency_hz=1000, duration_s=0.001)


# A short MIMO measurement: 2 periods of each block.
FRF = dict(from_hz=50.0, to_hz=2000.0, amplitude_v=1.0, bias_v=5.0, periods=2)
FRF_CLI = ["--from-hz", "50", "--to-hz", "2000", "--amplitude-v", "1", "--bias-v", "5", "--periods", "2"]


def read_csv(path):
    """The MIMO FRF CSV (host/measure/mimo_frf_file.hpp) as arrays."""
    with open(path) as f:
        lines = f.read().splitlines()
    header = dict(kv.split("=") for kv in lines[1][1:].split())
    n_in, n_out = int(header["inputs"]), int(header["outputs"])
    rows = list(csv.DictReader(lines[2:]))
    f_hz = np.array([float(r["f_Hz"]) for r in rows])
    g = np.array([[[complex(float(r[f"G{i + 1}{j + 1}_re"]), float(r[f"G{i + 1}{j + 1}_im"])) for j in range(n_in)]
                   for i in range(n_out)] for r in rows])
    sd = np.array([[[float(r[f"G{i + 1}{j + 1}_std"]) for j in range(n_in)] for i in range(n_out)] for r in rows])
    return f_hz, g, sd


def without_text(j):
    return {k: v for k, v in j.items() if k not in ("file", "meaning")}


def test_mimo_frf_and_coupling_equal_cli(tmp_path):
    res = piezoloop.measure_frf(XY, mimo=True, **FRF)
    out = str(tmp_path / "xy.csv")
    ref = json.loads(cli("measure", "frf", "--scenario", XY, "--mimo", *FRF_CLI, "--out", out))
    assert res.log_hash == ref["log_hash"] and res.axes == ["x", "y"] == ref["axes"]
    f_hz, g, sd = read_csv(out)
    # 17 significant digits in the CSV: the same doubles.
    np.testing.assert_array_equal(res.frequency_hz, f_hz)
    np.testing.assert_array_equal(res.response, g)
    np.testing.assert_array_equal(res.std, sd)
    assert res.response.shape == (len(f_hz), 2, 2)
    c = piezoloop.analyze_coupling(res)
    assert c == without_text(json.loads(cli("analyze", "coupling", out)))
    # Saved by the module: the same file, read the same way.
    mine = tmp_path / "mine.csv"
    res.save_csv(mine)
    assert mine.read_text() == open(out).read()
    assert piezoloop.analyze_coupling(mine) == c

    # Measured through the decoupling matrix: as the CLI with --output-matrix,
    # and the low-frequency coupling is the one analyze_coupling predicted
    # for G(f) D (after_lines) to within 1 dB: the channel stage applies D
    # in float32 and two periods of a hysteretic stage are not a linear G
    # (measured: 0.06 and 0.45 dB apart, 4 and 2 dB below the coupling
    # without D).
    d = c["output_matrix"]
    mfile = tmp_path / "d.json"
    mfile.write_text(json.dumps({"output_matrix": d}))
    dec = piezoloop.measure_frf(XY, mimo=True, output_matrix=np.array(d), **FRF)
    out2 = str(tmp_path / "xy_d.csv")
    ref2 = json.loads(cli("measure", "frf", "--scenario", XY, "--mimo", *FRF_CLI, "--out", out2, "--output-matrix",
                          str(mfile)))
    assert dec.log_hash == ref2["log_hash"] and dec.report["output_matrix"] == "given"
    np.testing.assert_array_equal(dec.response, read_csv(out2)[1])
    c2 = piezoloop.analyze_coupling(dec)
    for predicted, measured in zip(c["after_lines"], c2["coupling"]):
        assert predicted["pair"] == measured["pair"]
        assert measured["low_frequency_db"] == pytest.approx(predicted["low_frequency_db"], abs=1.0), measured


def test_mimo_refusals():
    with pytest.raises(ValueError, match=r"output_matrix: must be n x n"):
        piezoloop.measure_frf(XY, mimo=True, output_matrix=[[1, 0, 0], [0, 1, 0]], **FRF)
    with pytest.raises(ValueError, match=r"output_matrix: must be 2 x 2"):
        piezoloop.measure_frf(XY, mimo=True, output_matrix=np.eye(3), **FRF)
    with pytest.raises(ValueError, match=r"^output_matrix: "):
        piezoloop.measure_frf(XY, mimo=True, output_matrix=[[1, 1], [1, 1]], **FRF)
    with pytest.raises(ValueError, match="output_matrix: only with mimo=True"):
        piezoloop.measure_frf(XY, 50.0, 2000.0, 2.0, output_matrix=np.eye(2))
    with pytest.raises(ValueError, match="case: not with mimo=True"):
        piezoloop.measure_frf(XY, mimo=True, case="open_loop", **FRF)
    with pytest.raises(ValueError, match="to_Hz: must be below the Nyquist"):
        piezoloop.measure_frf(XY, 50.0, 1e6, 1.0, bias_v=5.0, mimo=True)
    with pytest.raises(TypeError, match="response"):
        piezoloop.analyze_coupling(42)


def test_board_of_axes_records_every_axis_as_the_cli_sim(tmp_path):
    """qemu-m3 with the XY flexure: the case sent with set_scenario, each
    axis's trajectory set with axis=, a record of y started with every
    axis's wave (every_axis) from rest: y's r and y equal `piezoloop sim
    --axis x --hold-um y=50 --start-together` bit for bit. An unknown axis,
    and an axis group without axis= on a board of axes, raise ValueError
    naming the axis. Then Device.scan from the restarted stage equals
    `piezoloop scan --board-start` tick by tick."""
    need_qemu("qemu-m3")
    xy = XY
    with piezoloop.emulate("qemu-m3", scenario=xy) as emu, piezoloop.connect(emu.address) as dev:
        sent = dev.set_scenario(xy, "pi_notch_decoupled")
        assert {"x.limits", "y.limits", "output_matrix"} <= set(sent["sent"])
        with pytest.raises(ValueError, match=r"axis: this board has 2 axes: give --axis x\|y"):
            dev.get("limits")
        with pytest.raises(ValueError, match=r"axis: 'w' is not an axis of this board"):
            dev.get("limits", axis="w")
        assert dev.get("output_matrix")["axis_count"] == 2
        dev.set("trajectory", axis="x", waveform="triangle", amplitude_um=40.0, offset_um=50.0, frequency_Hz=10.0)
        y = dev.set("trajectory", axis="y", waveform="sine", amplitude_um=0.0, offset_um=50.0, frequency_Hz=10.0)
        assert y["offset_um"] == 50.0
        rec = dev.record(0.1, "r,y", axis="y", start_wave=True, every_axis=True, restart_stage=True)
        # A scan from the stage at rest after the waves (the held setpoints
        # and the reference pre-filters elsewhere): Device.scan equals the
        # simulator started as the board starts it, tick by tick.
        dev.stop()
        dev.disarm()
        scanned = dev.scan("raster", size_um=(20, 20), pixels=(16, 16), line_rate_hz=100, scenario=xy,
                           restart_stage=True)
        with pytest.raises(ValueError, match="centre_um"):
            dev.scan("raster", size_um=(20, 20), pixels=(16, 16), line_rate_hz=100)
        # The n x n response on the board, one axis at a time, through the
        # identity output matrix: the diagonal within 1 dB of the
        # simulator's orthogonal multisines (as cli_axes_e2e checks the CLI's).
        dev.disarm()
        dev.set("output_matrix", axis_count=2, gain=[1, 0, 0, 0, 1, 0, 0, 0, 1])
        with pytest.raises(ValueError, match="axis: not with mimo"):
            dev.measure_frf(20, 2000, 0.1, bias_v=5, mimo=True, axis="x")
        board_frf = dev.measure_frf(20, 2000, 0.1, bias_v=5, mimo=True)
    sim_frf = piezoloop.measure_frf(xy, 20, 2000, 0.1, bias_v=5, mimo=True)
    assert board_frf.report["design"] == "one axis at a time" and board_frf.axes == ["x", "y"]
    assert board_frf.response.shape == sim_frf.response.shape and board_frf.response.shape[1:] == (2, 2)
    diag = [abs(20 * math.log10(abs(b[i, i]) / abs(q[i, i])))
            for b, q in zip(board_frf.response, sim_frf.response) for i in range(2)]
    assert max(diag) < 1.0, max(diag)
    scan_dir = tmp_path / "scan"
    cli("scan", "--scenario", xy, "--case", "pi_notch_decoupled", "--sample-type", "q31", "--board-start",
        "--pattern", "raster", "--size-um", "20x20", "--pixels", "16x16", "--line-rate-hz", "100",
        "--out", str(scan_dir))
    with open(scan_dir / "scan.csv") as f:
        sim_scan = list(csv.DictReader(f))
    nine = lambda v: [float(f"{x:.9g}") for x in v]
    assert scanned.figures["complete"] and scanned.figures["sync_mismatches"] == 0
    for col in ("commanded_x_um", "commanded_y_um", "measured_x_um", "measured_y_um"):
        assert nine(scanned.ticks[col]) == [float(r[col]) for r in sim_scan], col
    assert [int(v) for v in scanned.ticks["sync"]] == [int(r["sync"]) for r in sim_scan]
    out = tmp_path / "sim.csv"
    cli("sim", "--scenario", xy, "--case", "pi_notch_decoupled", "--sample", "q31", "--axis", "x", "--hold-um",
        "y=50", "--start-together", "--trajectory", "triangle", "--frequency-hz", "10", "--amplitude-um", "80",
        "--midpoint-um", "50", "--duration-s", "0.1", "--out", str(out))
    with open(out) as f:
        ref = list(csv.DictReader(f))
    # y's record runs its own approach (longer than x's) plus 0.1 s: the
    # simulator's rows are x's approach plus 0.1 s.
    n = min(len(rec.signals["r_um"]), len(ref))
    assert rec.complete and n >= 2000
    # The CSV's 9 significant digits: the record's values at the same.
    nine = lambda v: [float(f"{x:.9g}") for x in v]
    assert nine(rec.signals["r_um"][:n]) == [float(r["r_y_um"]) for r in ref[:n]]
    assert nine(rec.signals["y_um"][:n]) == [float(r["y_y_um"]) for r in ref[:n]]
