"""A board from Python, end to end on qemu-m7, mirroring
tests/host/cli/check_device_e2e.py: emulate the Ahmad2020 stage, load the
dahl_ff_K case, record a run from rest; r, y, e, u and the log hash equal
piezoloop.sim's for the same case, nothing lost. Errors: a bad address, a
bad field name, an out-of-range value (the board's group unchanged)."""
import numpy as np
import pytest

import piezoloop
from conftest import need_qemu, scenario

CASE, F_HZ, AMP_UM, DUR_S = "dahl_ff_K", 10.0, 12.0, 0.2


@pytest.fixture(scope="module")
def board():
    need_qemu("qemu-m7")
    with piezoloop.emulate("qemu-m7", scenario=scenario("ahmad2020")) as emu:
        with piezoloop.connect(emu.address) as dev:
            yield dev


def test_record_equals_sim(board):
    sent = board.set_scenario(scenario("ahmad2020"), CASE, frequency_hz=F_HZ)
    assert {"limits", "feedforward", "feedback"} <= set(sent["sent"])
    # The scenario allows 12 V, the emulated board 10 V: clipped and said so.
    assert any(c.startswith("limits.u_max_V") for c in sent["clipped"])
    assert board.get("feedback")["kind"] == "sos"
    rec = board.record(DUR_S, "r,y,e,u", trajectory="triangle", frequency_hz=F_HZ, amplitude_um=AMP_UM,
                       scenario=scenario("ahmad2020"), start_wave=True, restart_stage=True)
    run = piezoloop.sim(scenario("ahmad2020"), CASE, frequency_hz=F_HZ, amplitude_um=AMP_UM, duration_s=DUR_S)
    assert rec.complete and rec.lost_blocks == 0
    assert rec.summary["frames"] == int(round(10000 * DUR_S))
    assert rec.log_hash == run.log_hash
    for name in ("r_um", "y_um", "u_V"):
        np.testing.assert_array_equal(rec.signals[name], run.signals[name], err_msg=name)
    assert rec.summary["e_max_um"] == run.metrics["e_max_um"]
    board.disarm()
    board.get("trajectory")  # the link still answers after the record
    assert board.status()["status"]["armed"] is False


def test_bad_field_name(board):
    with pytest.raises(ValueError, match=r"limits\.u_maxx_V"):
        board.set("limits", u_maxx_V=5.0)


def test_out_of_range_value_leaves_group_unchanged(board):
    before = board.get("limits")
    with pytest.raises(piezoloop.DeviceError, match=r"limits\.u_max_V"):
        board.set("limits", u_max_V=50.0)
    assert board.get("limits") == before


def test_unknown_group(board):
    with pytest.raises(ValueError, match="feedforward"):
        board.get("nonsense")


def test_bad_address():
    with pytest.raises(piezoloop.LinkError):
        piezoloop.connect("tcp:127.0.0.1:1", timeout_s=0.5)
    with pytest.raises(piezoloop.LinkError, match="tcp:"):
        piezoloop.connect("carrier-pigeon:7")
    with pytest.raises(ValueError):
        piezoloop.connect("")
