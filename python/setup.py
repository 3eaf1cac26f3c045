"""Builds the extension module _piezoloop with the host CMake preset (the
one `./tools/test` builds into build/host/python) and installs it with the
pure-Python files: the installed package is the build tree's, byte for byte.

It keeps _build_paths.py, so emulate() finds this checkout's `piezoloop`
executable and firmware images (or $PIEZOLOOP_EXE / the PATH if they are
gone). Run through pip (pyproject.toml), not directly.
"""
import glob
import os
import shutil
import subprocess

from setuptools import Distribution, setup
from setuptools.command.build_py import build_py

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
BUILD = os.path.join(ROOT, "build", "host")
BUILT_PACKAGE = os.path.join(BUILD, "python", "piezoloop")


class BuildWithCMake(build_py):
    def run(self):
        if not os.path.exists(os.path.join(BUILD, "build.ninja")):
            subprocess.check_call(["cmake", "--preset", "host"], cwd=ROOT)
        subprocess.check_call(["cmake", "--build", BUILD, "--target", "piezoloop_python"], cwd=ROOT)
        super().run()
        target = os.path.join(self.build_lib, "piezoloop")
        built = glob.glob(os.path.join(BUILT_PACKAGE, "_piezoloop*.so")) + [os.path.join(BUILT_PACKAGE, "_build_paths.py")]
        for f in built:
            shutil.copy2(f, target)


class BinaryDistribution(Distribution):
    """A wheel tagged for this Python and platform (it holds an extension)."""

    def has_ext_modules(self):
        return True


setup(cmdclass={"build_py": BuildWithCMake}, distclass=BinaryDistribution)
