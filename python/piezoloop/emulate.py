"""piezoloop.emulate: an emulated board (QEMU) for the length of a `with`.

It runs the `piezoloop emulate` command line as a child process, which
starts QEMU, waits until the board answers and prints one JSON line with
its address; leaving the block sends it SIGTERM, which stops QEMU. The
executable is the build tree's (recorded at build time), else
$PIEZOLOOP_EXE, else `piezoloop` on the PATH.
"""
from __future__ import annotations

import json
import os
import shutil
import signal
import subprocess
from typing import Optional


def _executable() -> str:
    exe = os.environ.get("PIEZOLOOP_EXE")
    if exe:
        return exe
    try:
        from ._build_paths import PIEZOLOOP_EXE
        if os.path.exists(PIEZOLOOP_EXE):
            return PIEZOLOOP_EXE
    except ImportError:
        pass
    exe = shutil.which("piezoloop")
    if exe is None:
        raise FileNotFoundError("no piezoloop executable: set PIEZOLOOP_EXE or put it on the PATH")
    return exe


class Emulator:
    """A running emulated board: .address ("tcp:127.0.0.1:PORT"), .info
    (the line `piezoloop emulate` printed: board, pid, firmware, ...)."""

    def __init__(self, board: str = "qemu-m7", scenario: Optional[str | os.PathLike] = None,
                 image: Optional[str | os.PathLike] = None, case: Optional[str] = None,
                 storage: Optional[str | os.PathLike] = None):
        if board not in ("qemu-m7", "qemu-m3"):
            raise ValueError(f"board: {board!r} is not one of qemu-m7, qemu-m3")
        cmd = [_executable(), "emulate", "--board", board]
        if scenario is not None:
            cmd += ["--scenario", os.fspath(scenario)]
        if case is not None:
            cmd += ["--case", case]
        if image is not None:
            cmd += ["--image", os.fspath(image)]
        if storage is not None:
            cmd += ["--storage", os.fspath(storage)]
        self._proc = subprocess.Popen(cmd, stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
        line = self._proc.stdout.readline()
        if not line:
            err = self._proc.stderr.read()
            self._proc.wait()
            raise _link_error(f"piezoloop emulate failed: {err.strip()}")
        self.info = json.loads(line)
        self.address: str = self.info["device"]

    def close(self) -> None:
        if self._proc.poll() is None:
            self._proc.send_signal(signal.SIGTERM)
            try:
                self._proc.wait(timeout=20)
            except subprocess.TimeoutExpired:
                self._proc.kill()
                self._proc.wait()
        for f in (self._proc.stdout, self._proc.stderr):
            f.close()

    def __enter__(self) -> "Emulator":
        return self

    def __exit__(self, *exc) -> None:
        self.close()


def _link_error(message: str) -> Exception:
    from ._piezoloop import LinkError
    return LinkError(message)


def emulate(board: str = "qemu-m7", scenario: Optional[str | os.PathLike] = None, *,
            image: Optional[str | os.PathLike] = None, case: Optional[str] = None,
            storage: Optional[str | os.PathLike] = None) -> Emulator:
    """Start an emulated board (as `piezoloop emulate`); use with `with`.
    scenario: its stage, loop rate and full scales (default the board's
    built-in profile); image: servo.elf (default: the build tree's
    build/fw-<board>/ or $PIEZOLOOP_FIRMWARE_DIR); storage: a host file the
    board keeps its parameter set in between runs (Device.save / load /
    forget; docs/storage.md), created empty if missing."""
    return Emulator(board, scenario, image, case, storage)
