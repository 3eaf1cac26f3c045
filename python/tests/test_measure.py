"""piezoloop.measure_frf and Device.measure_frf against the command line:
the simulator's response and log hash equal `piezoloop measure frf
--scenario`'s; on qemu-m7 the board's equal the simulator's bit for bit and
the board's groups are put back; bad requests raise ValueError naming the
option before anything moves."""
import json

import numpy as np
import pytest

import piezoloop
from conftest import cli, need_qemu, scenario

REQ = dict(from_hz=20.0, to_hz=4000.0, amplitude_v=0.09, bias_v=3.0, periods=4)


def test_sim_equals_command_line(tmp_path):
    r = piezoloop.measure_frf(scenario("ahmad2020"), **REQ)
    out = tmp_path / "frf.json"
    cli("measure", "frf", "--scenario", scenario("ahmad2020"), "--from-hz", "20", "--to-hz", "4000",
        "--amplitude-v", "0.09", "--bias-v", "3", "--periods", "4", "--out", str(out))
    ref = json.loads(out.read_text())
    assert r.log_hash == ref["log_hash"]
    np.testing.assert_array_equal(r.frequency_hz, ref["frequency_Hz"])
    np.testing.assert_array_equal(r.response, [complex(a, b) for a, b in ref["response"]])
    assert r.coherence is None and r.sensitivity is None
    # What save() writes, identify tf reads.
    r.save(tmp_path / "saved.json")
    cli("identify", "tf", "--frf", str(tmp_path / "saved.json"), "--order", "6/5", "--out",
        str(tmp_path / "model.json"))
    assert (tmp_path / "model.json").exists()


def test_sim_closed_loop_has_sensitivity():
    r = piezoloop.measure_frf(scenario("ahmad2020"), 20.0, 4000.0, 0.5, bias_v=3.0, mode="closed",
                              case="dahl_ff_K", periods=2)
    t = np.array([complex(a, b) for a, b in r.report["complementary_sensitivity"]])
    np.testing.assert_allclose(r.sensitivity + t, 1.0, atol=1e-12)


@pytest.mark.parametrize("kwargs, option", [
    (dict(REQ, amplitude_v=20.0), "--amplitude-v"),
    (dict(REQ, to_hz=1e6), "--to-hz"),
    (dict(REQ, periods=0), "--periods"),
    (dict(REQ, amplitude_v=float("nan")), "--amplitude-v"),
])
def test_bad_requests(kwargs, option):
    with pytest.raises(ValueError, match=option):
        piezoloop.measure_frf(scenario("ahmad2020"), **kwargs)


def test_bad_mode_and_signal():
    with pytest.raises(ValueError, match="mode"):
        piezoloop.measure_frf(scenario("ahmad2020"), **REQ, mode="sideways")
    with pytest.raises(ValueError, match="signal"):
        piezoloop.measure_frf(scenario("ahmad2020"), **REQ, signal="chirp")


def test_board_equals_sim():
    need_qemu("qemu-m7")
    with piezoloop.emulate("qemu-m7", scenario=scenario("ahmad2020")) as emu:
        with piezoloop.connect(emu.address) as dev:
            dev.set_scenario(scenario("ahmad2020"), "dahl_ff_K")
            dev.set("recorder", channels=["r", "y", "e", "u"], mode="continuous")
            before = dev.get("all")
            with pytest.raises(ValueError, match="--amplitude-v"):
                dev.measure_frf(**dict(REQ, amplitude_v=20.0))
            b = dev.measure_frf(**REQ, restart_stage=True)
            assert dev.get("all") == before
            assert dev.status()["status"]["armed"] is False
    s = piezoloop.measure_frf(scenario("ahmad2020"), **REQ)
    assert b.log_hash == s.log_hash
    np.testing.assert_array_equal(b.response, s.response)
    assert b.report["recording"]["lost_blocks"] == 0


STEP = dict(step_v=1.0, bias_v=2.0, duration_s=0.02)
LOOPS = dict(amplitudes_v=[2.0, 4.0], bias_v=1.0, frequency_hz=20.0, cycles=2)


def test_step_equals_command_line(tmp_path):
    r = piezoloop.measure_step(scenario("ahmad2020"), **STEP)
    out = tmp_path / "step.json"
    cli("measure", "step", "--scenario", scenario("ahmad2020"), "--step-v", "1", "--bias-v", "2",
        "--duration-s", "0.02", "--out", str(out))
    ref = json.loads(out.read_text())
    assert r.log_hash == ref["log_hash"]
    np.testing.assert_array_equal(r.response_um, ref["response_um"])
    np.testing.assert_array_equal(r.command_v, ref["command_V"])
    assert r.figures["overshoot_pct"] == ref["overshoot_pct"]
    assert r.time_s[0] < 0 and r.response_um.size == r.time_s.size


def test_closed_step_needs_a_case_and_checks_the_range():
    with pytest.raises(ValueError, match="case"):
        piezoloop.measure_step(scenario("ahmad2020"), step_um=2.0)
    with pytest.raises(ValueError, match="step_um"):
        piezoloop.measure_step(scenario("ahmad2020"), step_um=2.0, step_v=1.0)
    with pytest.raises(ValueError, match="--step-um"):
        piezoloop.measure_step(scenario("ahmad2020"), step_um=1e4, case="dahl_ff_K")
    r = piezoloop.measure_step(scenario("ahmad2020"), step_um=2.0, case="dahl_ff_K", duration_s=0.02)
    assert abs(r.figures["final_value_um"] - r.figures["initial_um"] - 2.0) < 0.05


def test_loops_equal_command_line(tmp_path):
    r = piezoloop.measure_loops(scenario("ahmad2020"), **LOOPS)
    csv, js = tmp_path / "loops.csv", tmp_path / "loops.json"
    cli("measure", "loops", "--scenario", scenario("ahmad2020"), "--amplitudes-v", "2,4", "--bias-v", "1",
        "--frequency-hz", "20", "--cycles", "2", "--out", str(csv), "--json", str(js))
    ref = json.loads(js.read_text())
    assert r.report["log_hash"] == ref["log_hash"]
    assert r.loops == ref["loops"]
    r.save_csv(tmp_path / "saved.csv")
    assert (tmp_path / "saved.csv").read_text() == csv.read_text()
    with pytest.raises(ValueError, match="shape"):
        piezoloop.measure_loops(scenario("ahmad2020"), [1.0], shape="square")
    with pytest.raises(ValueError, match="--amplitudes-v"):
        piezoloop.measure_loops(scenario("ahmad2020"), [500.0])


def test_board_step_and_loops():
    need_qemu("qemu-m7")
    with piezoloop.emulate("qemu-m7", scenario=scenario("ahmad2020")) as emu:
        with piezoloop.connect(emu.address) as dev:
            dev.set_scenario(scenario("ahmad2020"), "dahl_ff_K")
            dev.set("recorder", channels=["r", "y", "e", "u"], mode="continuous")
            before = dev.get("all")
            with pytest.raises(ValueError, match="--step-v"):
                dev.measure_step(step_v=500.0)
            b = dev.measure_step(**STEP, restart_stage=True)
            loops = dev.measure_loops([2.0], bias_v=1.0, frequency_hz=20.0, cycles=2)
            assert dev.get("all") == before
            assert dev.status()["status"]["armed"] is False
    s = piezoloop.measure_step(scenario("ahmad2020"), **STEP)
    assert b.log_hash == s.log_hash
    np.testing.assert_array_equal(b.response_um, s.response_um)
    assert b.report["source"]["kind"] == "board"
    assert len(loops.loops) == 1 and loops.loops[0]["hysteresis_pct"] > 1.0
