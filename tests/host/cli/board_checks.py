"""What the end-to-end checks against an emulated board share: the ok/FAIL
tally, the skip without QEMU or an image, and emulated boards that are
always stopped with SIGTERM (emulate then stops its QEMU; SIGKILL would
leave QEMU spinning a core), also when a check fails."""
import json
import os
import shutil
import signal
import subprocess
import sys


class Checks:
    def __init__(self):
        self.passed = self.failed = 0

    def __call__(self, ok, what, detail=""):
        if ok:
            self.passed += 1
            print("ok   " + what)
        else:
            self.failed += 1
            print("FAIL " + what + (f": {detail}" if detail else ""))
        return ok

    def exit(self):
        print(f"{self.passed} passed, {self.failed} failed")
        sys.exit(1 if self.failed else 0)


def skip_without_qemu(image):
    """Exit 77 (CTest: skipped) without qemu-system-arm or the firmware image."""
    if not os.path.exists(image) or shutil.which(os.environ.get("QEMU_SYSTEM_ARM", "qemu-system-arm")) is None:
        print(f"skipped: no QEMU or no image {image}")
        sys.exit(77)


class Emulators:
    """`piezoloop emulate` processes, stopped by stop() or stop_all()."""

    def __init__(self, exe):
        self.exe = exe
        self.running = []

    def start(self, *args):
        """emulate ARGS; returns (process, ["--device", address], emulate's JSON line)."""
        emu = subprocess.Popen([self.exe, "emulate", *args], stdout=subprocess.PIPE, stderr=subprocess.PIPE,
                               text=True)
        self.running.append(emu)
        info = json.loads(emu.stdout.readline())
        return emu, ["--device", info["device"]], info

    @staticmethod
    def stop(emu):
        if emu.poll() is None:
            emu.send_signal(signal.SIGTERM)
            try:
                emu.wait(timeout=20)
            except subprocess.TimeoutExpired:
                emu.kill()
                emu.wait()
        return emu.returncode

    def stop_all(self):
        for emu in self.running:
            self.stop(emu)
