"""The documented install (docs/python.md): `pip install --no-build-isolation
--no-index ./python` into a fresh virtual environment (with Debian's
numpy and setuptools) gives a package that imports from outside the
checkout and computes what the command line does."""
import os
import subprocess
import sys

import pytest

from conftest import SOURCE_DIR, cli, scenario


def test_pip_install_into_a_venv(tmp_path):
    venv = tmp_path / "venv"
    subprocess.run([sys.executable, "-m", "venv", "--system-site-packages", str(venv)], check=True)
    python = str(venv / "bin" / "python")
    env = {k: v for k, v in os.environ.items() if k not in ("PYTHONPATH", "PIEZOLOOP_EXE")}
    r = subprocess.run([python, "-m", "pip", "install", "-q", "--no-build-isolation", "--no-index",
                        os.path.join(SOURCE_DIR, "python")], capture_output=True, text=True, env=env, timeout=600)
    if r.returncode != 0 and "No module named pip" in r.stderr:
        pytest.skip("no pip in the venv (Debian: python3-venv, python3-pip)")
    assert r.returncode == 0, r.stderr
    code = ("import piezoloop, sys; r = piezoloop.sim(sys.argv[1], 'dahl_ff_K', frequency_hz=10.0, "
            "amplitude_um=5.0, duration_s=0.1); print(piezoloop.__file__); print(r.log_hash)")
    r = subprocess.run([python, "-c", code, scenario("ahmad2020")], capture_output=True, text=True, env=env,
                       cwd=tmp_path, timeout=120, check=True)
    where, log_hash = r.stdout.split()
    assert where.startswith(str(venv))
    ref = cli("sim", "--scenario", scenario("ahmad2020"), "--case", "dahl_ff_K", "--frequency-hz", "10",
              "--amplitude-um", "5", "--duration-s", "0.1", "--hash").strip()
    assert log_hash == ref
