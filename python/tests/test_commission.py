"""piezoloop.commission and Device.commission against the command line: on
the simulator the summary equals `piezoloop commission --scenario`'s (the
same implementation: the same candidates, choice and verification figures)
and the progress lines arrive; bad requests raise ValueError naming the
option, before anything moves; on qemu-m7 a board without limits and a
range beyond its travel are refused, the board left disarmed, its groups as
they were, with nothing stored."""
import json
import os

import pytest

import piezoloop
from conftest import cli, firmware, need_qemu, scenario

# What differs between two runs: where the files went and how long it took.
VOLATILE = ("report", "controller_file", "scenario_file", "wall_s")


def test_sim_equals_command_line(tmp_path):
    lines = []
    s = piezoloop.commission(scenario("ahmad2020"), 12.0, tmp_path / "py", progress=lines.append)
    ref = json.loads(cli("commission", "--scenario", scenario("ahmad2020"), "--range-um", "12", "--out",
                         str(tmp_path / "cli")))
    for key in VOLATILE:
        s.pop(key, None)
        ref.pop(key, None)
    assert s == ref
    assert s["verified"] is True
    assert any(line.startswith("safety step") for line in lines) and lines[-1].startswith("verified")
    for name in ("report.md", "controller.json", "frf.json", "scenario.json", "frf.png"):
        assert os.path.exists(tmp_path / "py" / name), name


def _strip(summary):
    """A summary without what differs between two runs (paths, wall time)."""
    if isinstance(summary, dict):
        return {k: _strip(v) for k, v in summary.items() if k not in VOLATILE}
    return summary


def test_axes_equal_command_line(tmp_path):
    xy = os.path.join(os.path.dirname(scenario("ahmad2020")), "stages", "xy_flexure.json")
    s = piezoloop.commission(xy, {"x": 80, "y": 80}, tmp_path / "py", axes=["x", "y"])
    ref = json.loads(cli("commission", "--scenario", xy, "--axes", "x,y", "--range-um", "80", "--out",
                         str(tmp_path / "cli")))
    assert _strip(s) == _strip(ref)
    assert s["verified"] and s["decoupled"]
    with pytest.raises(ValueError, match="--axes"):
        piezoloop.commission(xy, 80, tmp_path / "x")
    with pytest.raises(ValueError, match="--axes"):
        piezoloop.commission(xy, 80, tmp_path / "x", axes=["x"])
    with pytest.raises(TypeError, match="axes"):
        piezoloop.commission(xy, 80, tmp_path / "x", axes="x,y")
    with pytest.raises(TypeError, match="range_um"):
        piezoloop.commission(scenario("ahmad2020"), {"x": 12}, tmp_path / "x")
    assert not os.path.exists(tmp_path / "x")


@pytest.mark.parametrize("kwargs, option", [
    (dict(range_um=1000.0), "--range-um"),
    (dict(range_um=-1.0), "--range-um"),
    (dict(range_um=12.0, target_bandwidth_hz=4000.0), "--target-bandwidth-hz"),
])
def test_bad_requests(tmp_path, kwargs, option):
    with pytest.raises(ValueError, match=option):
        piezoloop.commission(scenario("ahmad2020"), out=tmp_path / "x", **kwargs)
    assert not os.path.exists(tmp_path / "x")
    with pytest.raises(TypeError, match="range_um"):
        piezoloop.commission(scenario("ahmad2020"), "12", tmp_path / "x")


def test_board_refuses_bad_requests(tmp_path):
    need_qemu("qemu-m7")
    store = tmp_path / "params.bin"
    with piezoloop.emulate("qemu-m7", scenario=scenario("ahmad2020"), storage=store) as emu:
        with piezoloop.connect(emu.address) as dev:
            # A board booted with the stage alone has no limits: the stage's
            # command range is the user's to give.
            with pytest.raises(ValueError, match="limits: the command span"):
                dev.commission(12.0, tmp_path / "out")
            dev.set("limits", u_min_V=-2.0, u_max_V=10.0, slew_V_per_s=200000.0)
            before = dev.get("all")
            with pytest.raises(ValueError, match="--range-um"):
                dev.commission(1000.0, tmp_path / "out")
            status = dev.status()["status"]
            assert status["armed"] is False and status["storage"]["at_boot"] == "empty"
            assert dev.get("all") == before
    assert not os.path.exists(tmp_path / "out")
    assert os.path.getsize(store) == 0
