"""The example script of python/examples runs and says board == simulator."""
import os
import subprocess
import sys

from conftest import SOURCE_DIR, need_qemu


def test_record_and_plot(tmp_path):
    need_qemu("qemu-m7")
    png = tmp_path / "out.png"
    r = subprocess.run([sys.executable, os.path.join(SOURCE_DIR, "python", "examples", "record_and_plot.py"),
                        str(png)], capture_output=True, text=True, timeout=120, env=os.environ.copy())
    assert r.returncode == 0, r.stdout + r.stderr
    assert "(equal)" in r.stdout and png.stat().st_size > 0
