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
    with pytest.raises(ValueError, match="tcp:"):  # a malformed address is bad input
        piezoloop.connect("carrier-pigeon:7")
    with pytest.raises(ValueError):
        piezoloop.connect("")


def test_wave_and_stop(board):
    board.disarm()
    w = board.wave("sine", 5.0, 4.0)
    assert w["wave_running"] is True and w["trajectory"]["waveform"] == "sine"
    assert board.status()["status"]["wave_running"] is True
    s = board.stop()
    assert s["wave_running"] is False and s["streaming"] is False
    with pytest.raises(ValueError, match="trajectory"):
        board.wave("zigzag", 5.0, 4.0)


def test_stream_is_consumed(board):
    board.stop()
    n = 500  # 0.05 s at the scenario's 10 kHz
    sp = 6.0 + 6.0 * np.sin(np.linspace(0.0, 2.0 * np.pi, n))
    r = board.stream(sp)
    assert r["consumed"] == n and r["sent"] == n and r["drained"] is True
    assert board.status()["status"]["streaming"] is False
    with pytest.raises(ValueError, match="setpoint"):
        board.stream([0.0, float("nan")])


def test_devices_lists_usb_boards():
    boards = piezoloop.devices()
    assert isinstance(boards, list)
    assert all({"device", "serial", "vid_pid"} <= set(b) for b in boards)


def test_board_gone_mid_record():
    """The board dies 0.5 s into a 5 s record: LinkError saying the record is
    incomplete, with what arrived."""
    import threading
    need_qemu("qemu-m7")
    emu = piezoloop.emulate("qemu-m7", scenario=scenario("ahmad2020"))
    try:
        with piezoloop.connect(emu.address) as dev:
            threading.Timer(0.5, emu.close).start()
            with pytest.raises(piezoloop.LinkError, match="incomplete") as e:
                dev.record(5.0, "r,y,u", stall_s=1.0)
            assert e.value.recording.summary["frames"] < 50000
    finally:
        emu.close()


def test_qemu_m3_record_equals_sim():
    """The Q31 board at 100 kHz: janaideh2016 / ff_fb (one 20 Hz period), as
    the command line's e2e check does, against piezoloop.sim with
    sample="q31"."""
    need_qemu("qemu-m3")
    sc = scenario("janaideh2016")
    with piezoloop.emulate("qemu-m3", scenario=sc) as emu, piezoloop.connect(emu.address) as dev:
        dev.set_scenario(sc, "ff_fb", frequency_hz=20.0)
        rec = dev.record(0.05, "r,y,u", trajectory="triangle", frequency_hz=20.0, amplitude_um=20.0, scenario=sc,
                         start_wave=True, restart_stage=True)
        dev.disarm()
    run = piezoloop.sim(sc, "ff_fb", frequency_hz=20.0, amplitude_um=20.0, duration_s=0.05, sample="q31")
    # The triangle starts at -20 um: the approach from the restarted stage's 0
    # comes first, in front of the 0.05 s asked for, on the board and in sim.
    assert rec.summary["approach_ticks"] > 0
    assert rec.lost_blocks == 0 and rec.summary["frames"] == 5000 + rec.summary["approach_ticks"]
    assert rec.log_hash == run.log_hash
