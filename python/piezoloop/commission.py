"""piezoloop.commission: a stage commissioned from measurements alone, as
`piezoloop commission --scenario` does (the board: Device.commission).

One implementation with the command line (host/cli/commission_session), so
the summary, the files it writes and the figures are those of the command.
See docs/commissioning.md.
"""
from __future__ import annotations

import os
from typing import Callable, Optional

from . import _piezoloop
from ._args import path


def check_commission(range_um: float, target_bandwidth_hz: Optional[float]) -> None:
    """The checks the command line makes of its options before anything
    runs (the C++ side names the same options for what it refuses)."""
    if not isinstance(range_um, (int, float)) or isinstance(range_um, bool):
        raise TypeError("range_um: a number")
    if target_bandwidth_hz is not None and (not isinstance(target_bandwidth_hz, (int, float)) or
                                            isinstance(target_bandwidth_hz, bool)):
        raise TypeError("target_bandwidth_hz: a number or None")


def commission(scenario: str | os.PathLike, range_um: float, out: str | os.PathLike, *,
               target_bandwidth_hz: Optional[float] = None,
               progress: Optional[Callable[[str], None]] = None) -> dict:
    """Commissions the scenario's stage (measured in open loop; its models
    are never read) for `range_um` of travel: safety steps, frequency
    response, hysteresis loop, fits, a robust and a classic candidate checked
    on the measured response, the best predicted verified on the stage.
    Writes report.md (with its figures), controller.json, frf.json and
    scenario.json to `out`; returns the summary (`summary["verified"]`).
    `progress` receives each step's line. Raises ValueError naming the
    option for a bad request, RuntimeError when a safety step stops it."""
    check_commission(range_um, target_bandwidth_hz)
    return _piezoloop.commission(path("scenario", scenario), float(range_um), float(target_bandwidth_hz or 0.0),
                                 path("out", out), progress)
