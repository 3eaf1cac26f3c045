"""Shared fixtures: the command line the package is checked against and the
source tree's configs (both recorded in the build's _build_paths)."""
import os
import shutil
import subprocess

import pytest

from piezoloop import _build_paths

SOURCE_DIR = _build_paths.SOURCE_DIR
CONFIGS = os.path.join(SOURCE_DIR, "configs")
EXE = os.environ.get("PIEZOLOOP_EXE", _build_paths.PIEZOLOOP_EXE)


def cli(*args, check=True):
    """Runs the command line; its stdout."""
    r = subprocess.run([EXE, *args], capture_output=True, text=True, timeout=120)
    if check and r.returncode != 0:
        raise AssertionError(f"piezoloop {' '.join(args)}: exit {r.returncode}: {r.stderr}")
    return r.stdout


def scenario(name):
    return os.path.join(CONFIGS, name + ".json")


def firmware(board):
    """The servo image `piezoloop emulate` would run, or None."""
    root = os.environ.get("PIEZOLOOP_FIRMWARE_DIR", os.path.join(SOURCE_DIR, "build"))
    path = os.path.join(root, f"fw-{board}", "firmware", "servo.elf")
    return path if os.path.exists(path) else None


def need_qemu(board):
    if shutil.which(os.environ.get("QEMU_SYSTEM_ARM", "qemu-system-arm")) is None:
        pytest.skip("no qemu-system-arm")
    if firmware(board) is None:
        pytest.skip(f"no {board} firmware (cmake --build --preset fw-{board})")
