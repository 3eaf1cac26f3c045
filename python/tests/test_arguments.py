"""The module checks its arguments as the command line checks its options
(one implementation: host/options/option_checks, sim::check_sim_request and
the measurement plans, called by both): out-of-range, NaN and negative
values raise ValueError naming the argument and the allowed range; a
fractional count, a wrong type or a 2-D array raises TypeError or
ValueError naming it, instead of being truncated, flattened or ignored. A
board's arguments are checked before anything is sent to it."""
import math

import numpy as np
import pytest

import piezoloop
from conftest import need_qemu, scenario

SC = scenario("ahmad2020")
CASE = "dahl_ff_K"


@pytest.mark.parametrize("kwargs,needle", [
    (dict(substeps=0, fidelity="double"), r"--substeps: must be in \[1, 10000\]"),
    (dict(substeps=-5), r"--substeps: must be in \[1, 10000\]"),
    (dict(log_every=-1), r"--log-every: must be in \[1, 1073741824\]"),
    (dict(frequency_hz=math.nan), r"--frequency-hz: must be in \[0.0001, 500000\] Hz \(got nan\)"),
    (dict(frequency_hz=7e5), r"--frequency-hz"),
    (dict(duration_s=-0.1), r"--duration-s"),
    (dict(amplitude_um=2e3), r"--amplitude-um: must be in \[1e-06, 1000\] um"),
    (dict(trajectory="square"), r"--trajectory: must be triangle or sine"),
])
def test_sim_ranges_as_the_cli(kwargs, needle):
    args = dict(frequency_hz=10.0, amplitude_um=5.0, duration_s=0.2)
    args.update(kwargs)
    with pytest.raises(ValueError, match=needle):
        piezoloop.sim(SC, CASE, **args)


@pytest.mark.parametrize("kwargs,name", [(dict(substeps=2.5), "substeps"), (dict(log_every=1.5), "log_every"),
                                         (dict(substeps="10"), "substeps")])
def test_sim_whole_numbers_not_truncated(kwargs, name):
    with pytest.raises(TypeError, match=name):
        piezoloop.sim(SC, CASE, frequency_hz=10.0, amplitude_um=5.0, duration_s=0.2, **kwargs)


def test_counts_not_truncated():
    with pytest.raises(TypeError, match="periods"):
        piezoloop.measure_frf(SC, 10.0, 1000.0, 0.1, periods=2.5)
    with pytest.raises(TypeError, match="transient_periods"):
        piezoloop.measure_frf(SC, 10.0, 1000.0, 0.1, transient_periods=1.2)
    with pytest.raises(TypeError, match="cycles"):
        piezoloop.measure_loops(SC, [1.0, 2.0], cycles=3.7)
    with pytest.raises(TypeError, match="order"):
        piezoloop.design.reduce({"num": [1], "den": [1, 3, 2]}, order=2.5)
    with pytest.raises(TypeError, match="d_order"):
        piezoloop.design.musyn({"num": [1], "den": [1, 1]}, {"num": [1], "den": [1, 1]}, {"num": [0.1], "den": [1]},
                               d_order=1.5)


def test_connect_timeout_checked_before_connecting():
    for bad in (-1, 0, math.nan, 1e6):
        with pytest.raises(ValueError, match=r"timeout_s: must be in \[0.001, 3600\] s"):
            piezoloop.connect("tcp:127.0.0.1:1", timeout_s=bad)
    with pytest.raises(TypeError, match="timeout_s"):
        piezoloop.connect("tcp:127.0.0.1:1", timeout_s="3")


@pytest.fixture(scope="module")
def board():
    need_qemu("qemu-m7")
    with piezoloop.emulate("qemu-m7", scenario=SC) as emu:
        with piezoloop.connect(emu.address) as dev:
            yield dev


@pytest.mark.parametrize("args,kwargs,needle", [
    ((1e12,), {}, r"--duration-s: must be in \[1e-06, 100000\] s \(got 1e\+12\)"),
    ((0.0,), {}, r"--duration-s"),
    ((0.05,), dict(stall_s=math.nan), r"--stall-s: must be in \[0.1, 3600\] s \(got nan\)"),
    ((0.05,), dict(stall_s=0.01), r"--stall-s"),
    ((0.05,), dict(decimation=0), r"--decimation: must be in \[1, 16777216\]"),
    ((0.05,), dict(decimation=-5), r"--decimation"),
])
def test_record_ranges_as_the_cli(board, args, kwargs, needle):
    with pytest.raises(ValueError, match=needle):
        board.record(*args, **kwargs)
    assert board.status()["status"]["recorder_state"] in ("idle", "done")


def test_record_signals_as_a_list(board):
    rec = board.record(0.01, ["r", "y"])
    assert set(rec.signals) == {"t_s", "r_um", "y_um"}
    rec = board.record(0.01, ("u",))
    assert set(rec.signals) == {"t_s", "u_V"}
    with pytest.raises(TypeError, match="signals"):
        board.record(0.01, [1, 2])
    with pytest.raises(ValueError, match="signals"):
        board.record(0.01, ["r,y"])
    with pytest.raises(TypeError, match="decimation"):
        board.record(0.01, "r", decimation=2.5)


def test_wave_checked_as_the_cli(board):
    with pytest.raises(ValueError, match=r"--frequency-hz: must be in \[0.0001, 500000\] Hz \(got nan\)"):
        board.wave("sine", math.nan, 4.0)
    with pytest.raises(ValueError, match=r"--amplitude-um: must be in \[1e-06, 1000\] um \(got -4\)"):
        board.wave("sine", 5.0, -4.0)
    with pytest.raises(ValueError, match=r"--trajectory: must be triangle, sine, square or raster"):
        board.record(0.01, trajectory="zigzag", amplitude_um=4.0)
    with pytest.raises(ValueError, match=r"--amplitude-um: required"):
        board.record(0.01, trajectory="sine")
    with pytest.raises(ValueError, match=r"--offset: must be unipolar or bipolar"):
        board.wave("sine", 5.0, 4.0, offset="centred")
    for bad in (-3, 2**32 + 7):
        with pytest.raises(ValueError, match=r"^cycles: must be in \[0, 4294967295\]"):
            board.wave("sine", 5.0, 4.0, cycles=bad)
    assert board.status()["status"]["wave_running"] is False


def test_prefilter_coefficient_named_as_the_group_holds_it(board):
    board.set("limits", u_min_V=-2.0, u_max_V=10.0, slew_V_per_s=200000.0)  # the core checks a whole set
    before = board.get("feedforward")
    lp = {"b0": 0.02, "b1": 0.04, "b2": 0.02, "a1": -1.56, "a2": 0.64}
    # Finite but a pole outside the unit circle: refused by the board's core.
    with pytest.raises(piezoloop.DeviceError, match=r"feedforward\.prefilter\[1\]\.a2: poles must be inside"):
        board.set("feedforward", prefilter=[lp, dict(lp, a2=1.25)])
    with pytest.raises(ValueError, match=r"feedforward\.prefilter\[0\]\.b1: must be a finite number"):
        board.set("feedforward", prefilter=[dict(lp, b1=math.inf)])
    assert board.get("feedforward") == before


def test_stream_checked_before_sending(board):
    board.stop()
    sp = np.full(50, 1.0)
    for bad in (-1, 10**9, 32769):
        with pytest.raises(ValueError, match=r"--prefill: must be in \[0, 32768\]"):
            board.stream(sp, prefill=bad)
    with pytest.raises(TypeError, match="prefill"):
        board.stream(sp, prefill=2.5)
    with pytest.raises(ValueError, match=r"setpoints_um: a 1-D sequence.*\(5, 10\)"):
        board.stream(np.ones((5, 10)))
    for bad in (["0.25", "0.5"], [0.1, None], [{"um": 1}]):
        with pytest.raises(TypeError, match="^setpoints_um: numbers"):
            board.stream(bad)
    assert board.status()["status"]["streaming"] is False


def test_set_none_and_nan_name_the_field(board):
    before = board.get("limits")
    with pytest.raises(ValueError, match=r"limits\.u_max_V: must not be null"):
        board.set("limits", u_max_V=None)
    with pytest.raises(ValueError, match=r"limits\.slew_V_per_s: must be a finite number \(got nan\)"):
        board.set("limits", slew_V_per_s=math.nan)
    with pytest.raises(ValueError, match=r"feedback\.sections\[0\]\.b0: must be a finite number \(got inf\)"):
        board.set("feedback", sections=[{"b0": math.inf}])
    assert board.get("limits") == before


@pytest.mark.parametrize("call,name", [
    (lambda: piezoloop.sim(SC, 7, frequency_hz=10.0, amplitude_um=5.0), "case"),
    (lambda: piezoloop.sim(SC, CASE, trajectory=["sine"], frequency_hz=10.0, amplitude_um=5.0), "trajectory"),
    (lambda: piezoloop.sim(SC, CASE, frequency_hz=10.0, amplitude_um=5.0, fidelity=1), "fidelity"),
    (lambda: piezoloop.sim(SC, CASE, frequency_hz=10.0, amplitude_um=5.0, offset=0.5), "offset"),
    (lambda: piezoloop.sim(None, CASE, frequency_hz=10.0, amplitude_um=5.0), "scenario"),
    (lambda: piezoloop.measure_frf(SC, "10", 1000.0, 0.1), "from_hz"),
    (lambda: piezoloop.measure_frf(SC, 10.0, 1000.0, 0.1, bias_v=[0.5]), "bias_v"),
    (lambda: piezoloop.measure_frf(SC, 10.0, 1000.0, 0.1, mode="closed", case=3), "case"),
    (lambda: piezoloop.measure_step(SC, step_v="0.5"), "step_v"),
    (lambda: piezoloop.measure_step(SC, step_v=0.5, duration_s="0.1"), "duration_s"),
    (lambda: piezoloop.measure_loops(SC, "1.5,3"), "amplitudes_v"),
    (lambda: piezoloop.measure_loops(SC, 2.5), "amplitudes_v"),
    (lambda: piezoloop.measure_loops(SC, [[1.0, 2.0]]), r"amplitudes_v\[0\]"),
    (lambda: piezoloop.measure_loops(SC, [1.0, "2"]), r"amplitudes_v\[1\]"),
    (lambda: piezoloop.commission(SC, 10.0, None), "out"),
])
def test_wrong_types_name_the_argument(call, name):
    """A string for a number, a number for a string, a scalar or a string for
    a list: TypeError naming the argument (not a C++ signature's dump, not
    float()'s message, not a string read character by character)."""
    with pytest.raises(TypeError, match="^" + name + ": "):
        call()
