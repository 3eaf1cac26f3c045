"""piezoloop from Python: the simulator, the design tools and the boards.

One implementation: every call goes to the C++ host library (the extension
module ``_piezoloop``) that the ``piezoloop`` command line uses, so a
simulation's ``log_hash`` equals ``piezoloop sim --hash`` and a board is
configured exactly as ``piezoloop --device ... set`` does. Units are in the
names: ``_um`` micrometres, ``_V`` volts, ``_s`` seconds, ``_hz`` hertz.
See docs/python.md.
"""
from . import _piezoloop
from . import design
from ._piezoloop import DeviceError, LinkError
from .commission import commission
from .device import Device, Recording, connect, devices
from .emulate import Emulator, emulate
from .measure import (FrequencyResponse, Loops, MimoFrequencyResponse, StepResponse, analyze_coupling, measure_frf,
                      measure_loops, measure_step)
from .scan import ScanImage, ScanResult, scan
from .simulate import SimRun, sim

__all__ = ["sim", "SimRun", "connect", "devices", "Device", "Recording", "emulate", "Emulator", "design", "measure_frf",
           "measure_step", "measure_loops", "FrequencyResponse", "StepResponse", "Loops",
           "MimoFrequencyResponse", "analyze_coupling", "commission", "LinkError",
           "DeviceError", "scan", "ScanResult", "ScanImage"]
