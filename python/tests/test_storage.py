"""The board's parameter storage from Python on qemu-m7 (docs/storage.md):
a set saved with Device.save() is applied when the board starts again with
the same storage file; a board without storage refuses save()."""
import pytest

import piezoloop
from conftest import need_qemu, scenario


def test_saved_set_survives_a_restart(tmp_path):
    need_qemu("qemu-m7")
    store = tmp_path / "params.bin"
    with piezoloop.emulate("qemu-m7", scenario=scenario("ahmad2020"), storage=store) as emu:
        with piezoloop.connect(emu.address) as dev:
            assert "storage" in dev.status()["hello"]["capabilities"]
            dev.set_scenario(scenario("ahmad2020"), "dahl_ff_K", frequency_hz=10.0)
            saved = dev.get("all")
            dev.save()
    with piezoloop.emulate("qemu-m7", scenario=scenario("ahmad2020"), storage=store) as emu:
        with piezoloop.connect(emu.address) as dev:
            st = dev.status()["status"]
            assert st["storage"]["at_boot"] == "applied"
            assert st["armed"] is False
            assert dev.get("all") == saved
            dev.forget()
            with pytest.raises(piezoloop.DeviceError, match="storage.record"):
                dev.load()


def test_no_storage_refuses_save():
    need_qemu("qemu-m7")
    with piezoloop.emulate("qemu-m7") as emu:
        with piezoloop.connect(emu.address) as dev:
            assert dev.status()["status"]["storage"]["at_boot"] == "absent"
            with pytest.raises(piezoloop.DeviceError, match="unsupported"):
                dev.save()
